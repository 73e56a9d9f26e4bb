#include "whitted.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>
#include <vector>

#include "rayclass/geometry/intersect.h"
#include "rayclass/geometry/offset.h"
#include "rayclass/render/device_scene.h"

namespace rayclass::bench {

namespace {

using glm::vec3;
constexpr uint32_t kTile = 8;  // pixels a tile side
constexpr uint32_t kNoHit = 0xFFFFFFFFu;

enum class Kind : uint8_t { kEye, kReflection, kRefraction };

struct PathRay {
    vec3 o, d, weight;
    uint32_t depth = 0, pixel = 0;
    Kind kind = Kind::kEye;
};

struct ShadowRay {
    vec3 o, d, contribution;
    float dist = 0;
    uint32_t pixel = 0;
};

struct Hit {
    float t = INFINITY, u = 0, v = 0;
    uint32_t prim = kNoHit;
};

struct Surface {
    vec3 p, ng, ns;
    bool entering = true;
    uint32_t material = 0;
};

float MaxComponent(const vec3& v) { return std::max(v.x, std::max(v.y, v.z)); }

float FresnelDielectric(float cosi, float eta) {
    const float sin2t = eta * eta * (1.0f - cosi * cosi);
    if (sin2t >= 1.0f) return 1.0f;
    const float cost = std::sqrt(1.0f - sin2t);
    const float rs = (eta * cosi - cost) / (eta * cosi + cost);
    const float rp = (cosi - eta * cost) / (cosi + eta * cost);
    return 0.5f * (rs * rs + rp * rp);
}

// The surface at a hit, in cl/shade.cl's float arithmetic (rc_surface).
Surface SurfaceAt(const scene::Scene& sc, const PathRay& ray, const Hit& hit) {
    Surface s;
    const uint32_t id = hit.prim;
    if (id < sc.SphereBase()) {
        const auto& tri = sc.triangles[id];
        const float w = 1.0f - hit.u - hit.v;
        s.p = w * tri.p[0] + hit.u * tri.p[1] + hit.v * tri.p[2];
        vec3 n = glm::cross(tri.p[1] - tri.p[0], tri.p[2] - tri.p[0]);
        const float len = glm::length(n);
        n = len > 0.0f ? n / len : -ray.d;
        s.ng = n;
        s.ns =
            tri.hasNormals ? glm::normalize(w * tri.n[0] + hit.u * tri.n[1] + hit.v * tri.n[2]) : n;
        s.material = tri.material;
    } else if (id < sc.QuadricBase()) {
        const auto& sp = sc.spheres[id - sc.SphereBase()];
        s.ng = glm::normalize(ray.o + hit.t * ray.d - sp.center);
        s.p = sp.center + sp.radius * s.ng;
        s.ns = s.ng;
        s.material = sp.material;
    } else {
        const auto& q = sc.quadrics[id - sc.QuadricBase()];
        s.p = ray.o + hit.t * ray.d;
        const vec3 g0 = geometry::QuadricGradient(q.c, s.p);
        const float gg = glm::dot(g0, g0);
        if (gg > 0.0f) s.p -= geometry::QuadricValue(q.c, s.p) / gg * g0;
        const vec3 g = geometry::QuadricGradient(q.c, s.p);
        const float len = glm::length(g);
        s.ng = len > 0.0f ? g / len : -ray.d;
        s.ns = s.ng;
        s.material = q.material;
    }
    s.entering = glm::dot(ray.d, s.ng) < 0.0f;
    if (!s.entering) s.ng = -s.ng;
    if (glm::dot(s.ns, s.ng) < 0.0f) s.ns = -s.ns;
    return s;
}

struct Counters {
    uint64_t eye = 0, shadow = 0, reflection = 0, refraction = 0;
};

// Traces the tiles a thread takes, generation by generation in packets of 16.
class TileTracer {
  public:
    TileTracer(const scene::Scene& sc, const EmbreeScene& es, const WhittedOptions& options,
               image::Image& img)
        : sc_(sc), es_(es), options_(options), img_(img) {
        rtcInitIntersectContext(&ctx_);
    }

    void Tile(uint32_t x0, uint32_t y0, const render::CameraBasis& camera) {
        rays_.clear();
        const vec3 origin(camera.position);
        const uint32_t x1 = std::min(x0 + kTile, camera.width);
        const uint32_t y1 = std::min(y0 + kTile, camera.height);
        // 4x4 blocks, so each packet of eye rays is one block.
        for (uint32_t by = y0; by < y1; by += 4) {
            for (uint32_t bx = x0; bx < x1; bx += 4) {
                for (uint32_t y = by; y < std::min(by + 4, y1); ++y) {
                    for (uint32_t x = bx; x < std::min(bx + 4, x1); ++x) {
                        rays_.push_back({origin, camera.DirectionFloat(x, y), vec3(1.0f), 0,
                                         y * camera.width + x, Kind::kEye});
                    }
                }
            }
        }
        while (!rays_.empty()) Generation();
    }

    Counters counters;

  private:
    void Generation() {
        // Eye rays and their shadow rays are coherent; mirror and refraction rays scatter, and
        // in coherent mode their packets traced no faster.
        ctx_.flags = rays_[0].depth == 0 ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT
                                         : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
        next_.clear();
        shadows_.clear();
        for (size_t p = 0; p < rays_.size(); p += 16) {
            const size_t m = std::min<size_t>(16, rays_.size() - p);
            Hit hits[16];
            Intersect16(p, m, hits);
            for (size_t k = 0; k < m; ++k) Shade(rays_[p + k], hits[k]);
        }
        for (size_t p = 0; p < shadows_.size(); p += 16) {
            Occluded16(p, std::min<size_t>(16, shadows_.size() - p));
        }
        rays_.swap(next_);
    }

    void Intersect16(size_t p, size_t m, Hit* hits) {
        alignas(64) int valid[16];
        alignas(64) RTCRayHit16 rh;
        for (size_t k = 0; k < 16; ++k) {
            const PathRay& r = rays_[p + std::min(k, m - 1)];
            valid[k] = k < m ? -1 : 0;
            rh.ray.org_x[k] = r.o.x, rh.ray.org_y[k] = r.o.y, rh.ray.org_z[k] = r.o.z;
            rh.ray.dir_x[k] = r.d.x, rh.ray.dir_y[k] = r.d.y, rh.ray.dir_z[k] = r.d.z;
            rh.ray.tnear[k] = 0.0f, rh.ray.tfar[k] = INFINITY;
            rh.ray.time[k] = 0.0f, rh.ray.mask[k] = 0xFFFFFFFFu;
            rh.ray.id[k] = unsigned(k), rh.ray.flags[k] = 0;
            rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
        }
        rtcIntersect16(valid, es_.handle(), &ctx_, &rh);
        for (size_t k = 0; k < m; ++k) {
            if (rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) continue;
            hits[k] = {rh.ray.tfar[k], rh.hit.u[k], rh.hit.v[k],
                       es_.GlobalId(rh.hit.geomID[k], rh.hit.primID[k])};
        }
    }

    void Occluded16(size_t p, size_t m) {
        alignas(64) int valid[16];
        alignas(64) RTCRay16 r16;
        for (size_t k = 0; k < 16; ++k) {
            const ShadowRay& r = shadows_[p + std::min(k, m - 1)];
            valid[k] = k < m ? -1 : 0;
            r16.org_x[k] = r.o.x, r16.org_y[k] = r.o.y, r16.org_z[k] = r.o.z;
            r16.dir_x[k] = r.d.x, r16.dir_y[k] = r.d.y, r16.dir_z[k] = r.d.z;
            r16.tnear[k] = 0.0f, r16.tfar[k] = r.dist;
            r16.time[k] = 0.0f, r16.mask[k] = 0xFFFFFFFFu;
            r16.id[k] = unsigned(k), r16.flags[k] = 0;
        }
        rtcOccluded16(valid, es_.handle(), &ctx_, &r16);
        counters.shadow += m;
        for (size_t k = 0; k < m; ++k) {
            if (r16.tfar[k] >= 0.0f)
                img_.rgb[shadows_[p + k].pixel] += shadows_[p + k].contribution;
        }
    }

    // rc_shade_ray: the hit's own radiance, its shadow rays and its secondary rays.
    void Shade(const PathRay& ray, const Hit& hit) {
        ++(ray.kind == Kind::kEye          ? counters.eye
           : ray.kind == Kind::kReflection ? counters.reflection
                                           : counters.refraction);
        if (ray.kind == Kind::kEye && !img_.id.empty()) img_.id[ray.pixel] = hit.prim;
        vec3& color = img_.rgb[ray.pixel];
        if (hit.prim == kNoHit) {
            color += ray.weight * sc_.background;
            return;
        }
        const Surface s = SurfaceAt(sc_, ray, hit);
        const scene::Material& m = sc_.materials[s.material];
        color += ray.weight * (m.emission + m.kd * sc_.ambient);
        for (const auto& light : sc_.lights) ShadeLight(ray, s, m, light);
        Spawn(ray, s, m);
    }

    // rc_shade_light: the light's contribution, to be added when its shadow ray is unblocked.
    void ShadeLight(const PathRay& ray, const Surface& s, const scene::Material& m,
                    const scene::PointLight& light) {
        const vec3 toLight = light.position - s.p;
        const float dist2 = glm::dot(toLight, toLight);
        const vec3 ldir = toLight / std::sqrt(dist2);
        const float cosl = glm::dot(s.ns, ldir);
        if (cosl <= 0.0f || glm::dot(s.ng, ldir) <= 0.0f) return;
        vec3 brdf = m.kd * cosl;
        if (MaxComponent(m.ks) > 0.0f) {
            const vec3 r = 2.0f * cosl * s.ns - ldir;
            const float cosb = std::max(glm::dot(r, -ray.d), 0.0f);
            brdf += m.ks * std::pow(cosb, m.shininess);
        }
        const vec3 c = ray.weight * light.intensity / dist2 * brdf;
        if (MaxComponent(c) <= 0.0f) return;
        const vec3 above = geometry::OffsetRayOrigin(s.p, s.ng);
        const vec3 toLightFromOrigin = light.position - above;
        const float dist = glm::length(toLightFromOrigin);
        shadows_.push_back({above, toLightFromOrigin / dist, c, dist, ray.pixel});
    }

    bool WorthSpawning(const vec3& w, uint32_t depth) const {
        return depth <= options_.maxDepth && MaxComponent(w) >= options_.minWeight;
    }

    void Spawn(const PathRay& ray, const Surface& s, const scene::Material& m) {
        if (std::max(MaxComponent(m.kr), MaxComponent(m.kt)) <= 0.0f) return;
        const vec3& d = ray.d;
        const float cosi = std::min(std::max(-glm::dot(d, s.ns), 0.0f), 1.0f);
        const float eta = s.entering ? 1.0f / m.ior : m.ior;
        const float sin2t = eta * eta * (1.0f - cosi * cosi);
        const bool tir = sin2t >= 1.0f;
        vec3 krEff = m.kr, ktEff = m.kt;
        if (m.fresnel) {
            const float f = FresnelDielectric(cosi, eta);
            krEff = m.kr + m.kt * f;
            ktEff = m.kt * (1.0f - f);
        } else if (tir) {
            krEff = m.kr + m.kt;
            ktEff = vec3(0.0f);
        }
        const uint32_t depth = ray.depth + 1;
        const vec3 wr = ray.weight * krEff;
        if (WorthSpawning(wr, depth)) {
            vec3 rdir = d + 2.0f * cosi * s.ns;
            if (glm::dot(rdir, s.ng) <= 0.0f) rdir = d - 2.0f * glm::dot(d, s.ng) * s.ng;
            next_.push_back({geometry::OffsetRayOrigin(s.p, s.ng), glm::normalize(rdir), wr, depth,
                             ray.pixel, Kind::kReflection});
        }
        const vec3 wt = ray.weight * ktEff;
        if (!tir && WorthSpawning(wt, depth)) {
            const vec3 tdir = eta * d + (eta * cosi - std::sqrt(1.0f - sin2t)) * s.ns;
            if (glm::dot(tdir, s.ng) < 0.0f) {
                next_.push_back({geometry::OffsetRayOrigin(s.p, -s.ng), glm::normalize(tdir), wt,
                                 depth, ray.pixel, Kind::kRefraction});
            }
        }
    }

    const scene::Scene& sc_;
    const EmbreeScene& es_;
    const WhittedOptions& options_;
    image::Image& img_;
    RTCIntersectContext ctx_;
    std::vector<PathRay> rays_, next_;
    std::vector<ShadowRay> shadows_;
};

}  // namespace

image::Image RenderWhitted(const scene::Scene& scene, const WhittedOptions& options,
                           WhittedStats& stats) {
    const int threads = options.threads > 0
                            ? options.threads
                            : int(std::max(1u, std::thread::hardware_concurrency()));
    const EmbreeScene es(scene, threads);
    stats.buildSeconds = es.buildSeconds();
    const auto t0 = std::chrono::steady_clock::now();
    const render::CameraBasis camera(scene.camera);
    image::Image img(camera.width, camera.height);
    if (options.ids) img.id.assign(img.PixelCount(), kNoHit);
    const uint32_t tilesX = (camera.width + kTile - 1) / kTile;
    const uint32_t nTiles = tilesX * ((camera.height + kTile - 1) / kTile);
    std::atomic<uint32_t> nextTile{0};
    std::vector<Counters> counters(static_cast<size_t>(threads));
    auto work = [&](int t) {
        TileTracer tracer(scene, es, options, img);
        for (uint32_t i = nextTile++; i < nTiles; i = nextTile++) {
            tracer.Tile(i % tilesX * kTile, i / tilesX * kTile, camera);
        }
        counters[size_t(t)] = tracer.counters;
    };
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) pool.emplace_back(work, t);
    work(0);
    for (auto& th : pool) th.join();
    stats.traceSeconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    for (const Counters& c : counters) {
        stats.eye += c.eye;
        stats.shadow += c.shadow;
        stats.reflection += c.reflection;
        stats.refraction += c.refraction;
    }
    return img;
}

}  // namespace rayclass::bench
