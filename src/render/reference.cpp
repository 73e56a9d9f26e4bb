#include "rayclass/render/reference.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <optional>
#include <thread>

#include "rayclass/geometry/intersect.h"
#include "rayclass/geometry/offset.h"
#include "rayclass/render/device_scene.h"
#include "rayclass/render/reference_bvh.h"

namespace rayclass::render {

namespace {

using V = glm::dvec3;
using Ray = geometry::Ray<double>;

struct Surface {
    V p, ng, ns;
    bool entering = true;
    uint32_t material = 0;
};

struct Counters {
    uint64_t eye = 0, shadow = 0, reflection = 0, refraction = 0, tests = 0;
};

double MaxComponent(const V& v) { return std::max(v.x, std::max(v.y, v.z)); }

double FresnelDielectric(double cosi, double eta) {
    const double sin2t = eta * eta * (1.0 - cosi * cosi);
    if (sin2t >= 1.0) return 1.0;
    const double cost = std::sqrt(1.0 - sin2t);
    const double rs = (eta * cosi - cost) / (eta * cosi + cost);
    const double rp = (cosi - eta * cost) / (cosi + eta * cost);
    return 0.5 * (rs * rs + rp * rp);
}

class Tracer {
  public:
    Tracer(const scene::Scene& scene, const RenderOptions& options, ReferenceQuery query)
        : scene_(scene), options_(options) {
        if (query == ReferenceQuery::kBvh) bvh_.emplace(scene, options.triangleTest);
    }

    // Adds the radiance along the ray, times `weight`, to `color`. For eye rays fills the AOVs.
    void Trace(const Ray& ray, const V& weight, uint32_t depth, V& color, Counters& counters,
               image::Image* aovImage, size_t pixel) const {
        const auto hit = Nearest(ray, counters);
        if (!hit.Valid()) {
            color += weight * V(scene_.background);
            return;
        }
        const Surface s = SurfaceAt(ray, hit);
        if (aovImage) {
            aovImage->depth[pixel] = float(hit.t);
            aovImage->id[pixel] = hit.prim;
            aovImage->normal[pixel] = glm::vec3(s.ns);
        }
        const scene::Material& m = scene_.materials[s.material];
        color += weight * (V(m.emission) + V(m.kd) * V(scene_.ambient));

        const V above = geometry::OffsetRayOrigin(s.p, s.ng);
        AddLights(ray, s, m, above, weight, color, counters);
        Spawn(ray, s, m, above, weight, depth + 1, color, counters);
    }

  private:
    geometry::Hit<double> Nearest(const Ray& ray, Counters& counters) const {
        if (bvh_) return bvh_->Nearest(ray, counters.tests);
        counters.tests += scene_.PrimitiveCount();
        return geometry::IntersectBruteForce(scene_, ray, options_.triangleTest);
    }

    bool Occluded(const Ray& ray, Counters& counters) const {
        if (bvh_) return bvh_->Occluded(ray, counters.tests);
        counters.tests += scene_.PrimitiveCount();
        return geometry::Occluded(scene_, ray, options_.triangleTest);
    }

    // Adds every light's direct contribution at `s` that no primitive blocks.
    void AddLights(const Ray& ray, const Surface& s, const scene::Material& m, const V& above,
                   const V& weight, V& color, Counters& counters) const {
        for (const auto& light : scene_.lights) {
            const V toLight = V(light.position) - s.p;
            const double dist2 = glm::dot(toLight, toLight);
            const V ldir = toLight / std::sqrt(dist2);
            const double cosl = glm::dot(s.ns, ldir);
            if (cosl <= 0.0 || glm::dot(s.ng, ldir) <= 0.0) continue;
            V brdf = V(m.kd) * cosl;
            if (MaxComponent(V(m.ks)) > 0.0) {
                const V r = 2.0 * cosl * s.ns - ldir;
                const double cosb = std::max(glm::dot(r, -ray.d), 0.0);
                brdf += V(m.ks) * std::pow(cosb, double(m.shininess));
            }
            const V c = weight * V(light.intensity) / dist2 * brdf;
            if (MaxComponent(c) <= 0.0) continue;
            const V toLightFromOrigin = V(light.position) - above;
            const double dist = glm::length(toLightFromOrigin);
            ++counters.shadow;
            if (!Occluded(Ray{above, toLightFromOrigin / dist, 0.0, dist}, counters)) color += c;
        }
    }

    // Traces the reflection and refraction rays of depth `next` that `s` spawns.
    void Spawn(const Ray& ray, const Surface& s, const scene::Material& m, const V& above,
               const V& weight, uint32_t next, V& color, Counters& counters) const {
        const V kr(m.kr), kt(m.kt);
        if (std::max(MaxComponent(kr), MaxComponent(kt)) <= 0.0) return;
        const double cosi = std::clamp(-glm::dot(ray.d, s.ns), 0.0, 1.0);
        const double eta = s.entering ? 1.0 / m.ior : double(m.ior);
        const double sin2t = eta * eta * (1.0 - cosi * cosi);
        const bool tir = sin2t >= 1.0;
        V krEff = kr, ktEff = kt;
        if (m.fresnel) {
            const double f = FresnelDielectric(cosi, eta);
            krEff = kr + kt * f;
            ktEff = kt * (1.0 - f);
        } else if (tir) {
            krEff = kr + kt;
            ktEff = V(0.0);
        }
        const V wr = weight * krEff;
        if (WorthSpawning(wr, next)) {
            V rdir = ray.d + 2.0 * cosi * s.ns;
            if (glm::dot(rdir, s.ng) <= 0.0) rdir = ray.d - 2.0 * glm::dot(ray.d, s.ng) * s.ng;
            ++counters.reflection;
            Trace(Ray{above, glm::normalize(rdir)}, wr, next, color, counters, nullptr, 0);
        }
        const V wt = weight * ktEff;
        if (!tir && WorthSpawning(wt, next)) {
            const V tdir = eta * ray.d + (eta * cosi - std::sqrt(1.0 - sin2t)) * s.ns;
            if (glm::dot(tdir, s.ng) < 0.0) {
                ++counters.refraction;
                Trace(Ray{geometry::OffsetRayOrigin(s.p, -s.ng), glm::normalize(tdir)}, wt, next,
                      color, counters, nullptr, 0);
            }
        }
    }

    bool WorthSpawning(const V& w, uint32_t depth) const {
        return depth <= options_.maxDepth && MaxComponent(w) >= double(options_.minWeight);
    }

    Surface SurfaceAt(const Ray& ray, const geometry::Hit<double>& hit) const {
        Surface s;
        const uint32_t id = hit.prim;
        if (id < scene_.SphereBase()) {
            const auto& tri = scene_.triangles[id];
            const V p0(tri.p[0]), p1(tri.p[1]), p2(tri.p[2]);
            const double w = 1.0 - hit.u - hit.v;
            s.p = w * p0 + hit.u * p1 + hit.v * p2;
            V n = glm::cross(p1 - p0, p2 - p0);
            const double len = glm::length(n);
            s.ng = len > 0.0 ? n / len : -ray.d;
            s.ns = tri.hasNormals
                       ? glm::normalize(w * V(tri.n[0]) + hit.u * V(tri.n[1]) + hit.v * V(tri.n[2]))
                       : s.ng;
            s.material = tri.material;
        } else if (id < scene_.QuadricBase()) {
            const auto& sp = scene_.spheres[id - scene_.SphereBase()];
            s.ng = glm::normalize(ray.o + hit.t * ray.d - V(sp.center));
            s.p = V(sp.center) + double(sp.radius) * s.ng;
            s.ns = s.ng;
            s.material = sp.material;
        } else {
            const auto& q = scene_.quadrics[id - scene_.QuadricBase()];
            // Newton step back onto the surface, as in cl/shade.cl.
            const auto c = geometry::QuadricCoefficients<double>(q);
            s.p = ray.o + hit.t * ray.d;
            const V g0 = geometry::QuadricGradient(c, s.p);
            const double gg = glm::dot(g0, g0);
            if (gg > 0.0) s.p -= geometry::QuadricValue(c, s.p) / gg * g0;
            const V g = geometry::QuadricGradient(c, s.p);
            const double len = glm::length(g);
            s.ng = len > 0.0 ? g / len : -ray.d;
            s.ns = s.ng;
            s.material = q.material;
        }
        s.entering = glm::dot(ray.d, s.ng) < 0.0;
        if (!s.entering) s.ng = -s.ng;
        if (glm::dot(s.ns, s.ng) < 0.0) s.ns = -s.ns;
        return s;
    }

    const scene::Scene& scene_;
    const RenderOptions& options_;
    std::optional<ReferenceBvh> bvh_;
};

}  // namespace

image::Image RenderReference(const scene::Scene& scene, const RenderOptions& options,
                             RenderStats& stats, ReferenceQuery query) {
    const auto t0 = std::chrono::steady_clock::now();
    const CameraBasis basis(scene.camera, options.window);
    const image::PixelRect& window = basis.window;
    image::Image img = NewImage(basis, options.aovs);
    const Tracer tracer(scene, options, query);
    std::atomic<uint32_t> nextRow{0};
    const unsigned nThreads = std::max(1u, std::thread::hardware_concurrency());
    std::vector<Counters> counters(nThreads);
    std::vector<std::thread> threads;
    for (unsigned t = 0; t < nThreads; ++t) {
        threads.emplace_back([&, t] {
            for (uint32_t row = nextRow++; row < window.Height(); row = nextRow++) {
                const uint32_t y = window.y0 + row;
                for (uint32_t x = window.x0; x < window.x1; ++x) {
                    const size_t pixel = size_t(row) * window.Width() + (x - window.x0);
                    V color(0.0);
                    ++counters[t].eye;
                    tracer.Trace(Ray{basis.position, basis.Direction(x, y)}, V(1.0), 0, color,
                                 counters[t], options.aovs ? &img : nullptr, pixel);
                    img.rgb[pixel] = glm::vec3(color);
                }
            }
        });
    }
    for (auto& th : threads) th.join();
    stats.width = basis.width;
    stats.height = basis.height;
    stats.device = "host reference (double)";
    stats.accel = query == ReferenceQuery::kBvh ? "bvh" : "brute";
    stats.nPrimitives = scene.PrimitiveCount();
    for (const auto& c : counters) {
        stats.raysByKind["eye"] += c.eye;
        stats.raysByKind["shadow"] += c.shadow;
        stats.raysByKind["reflection"] += c.reflection;
        stats.raysByKind["refraction"] += c.refraction;
        stats.intersectionTests += c.tests;
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    stats.queryTimeS = seconds;
    stats.timeS["render"] = seconds;
    return img;
}

}  // namespace rayclass::render
