#include "hit_oracle.h"

#include <cmath>
#include <sstream>

#include "rayclass/geometry/intersect.h"

namespace rayclass::proof {

namespace {

geometry::Ray<float> HostRay(const RcRay& r) {
    return {{r.origin.x, r.origin.y, r.origin.z},
            {r.direction.x, r.direction.y, r.direction.z},
            r.origin.w,
            r.direction.w};
}

std::string Describe(const RcRay& r) {
    std::ostringstream s;
    s.precision(9);
    s << "ray o (" << r.origin.x << ", " << r.origin.y << ", " << r.origin.z << ") d ("
      << r.direction.x << ", " << r.direction.y << ", " << r.direction.z << ") t in (" << r.origin.w
      << ", " << r.direction.w << ")";
    return s.str();
}

bool SameHit(const RcHit& got, const geometry::Hit<float>& want) {
    if (got.prim != want.prim) return false;
    return got.prim == RC_NO_HIT || std::memcmp(&got.t, &want.t, sizeof(float)) == 0;
}

const char* KindName(uint32_t kind) {
    switch (kind) {
        case RC_RAY_EYE:
            return "eye";
        case RC_RAY_SHADOW:
            return "shadow";
        case RC_RAY_REFLECTION:
            return "reflection";
        case RC_RAY_REFRACTION:
            return "refraction";
        default:
            return "unknown";
    }
}

}  // namespace

uint64_t Tally::Mismatches() const {
    uint64_t n = 0;
    for (const auto& [kind, c] : byKind) n += c.mismatches + c.bruteMismatches;
    return n;
}

std::string Tally::Summary() const {
    std::ostringstream s;
    for (const auto& [kind, c] : byKind) {
        s << " " << kind << " " << c.rays << " rays (" << c.hits << " hit/blocked, " << c.mismatches
          << " mismatches; " << c.bruteChecked << " by brute force, " << c.bruteMismatches
          << " mismatches)";
    }
    return s.str();
}

HitOracle::HitOracle(const scene::Scene& scene, uint32_t bruteEvery)
    : scene_(scene), bvh_(scene, geometry::TriangleTest::kMoller), bruteEvery_(bruteEvery) {}

void HitOracle::Mismatch(const std::string& what) {
    if (tally_.firstMismatches.size() < 10) tally_.firstMismatches.push_back(what);
}

void HitOracle::CheckNearest(const std::string& kind, const RcRay& ray, const RcHit& hit) {
    Tally::Count& c = tally_.byKind[kind];
    const geometry::Ray<float> r = HostRay(ray);
    uint64_t tests = 0;
    const geometry::Hit<float> want = bvh_.Nearest(r, tests);
    ++c.rays;
    c.hits += want.Valid();
    if (!SameHit(hit, want)) {
        ++c.mismatches;
        std::ostringstream s;
        s.precision(9);
        s << kind << " " << Describe(ray) << ": query prim " << hit.prim << " t " << hit.t
          << ", brute force prim " << want.prim << " t " << want.t;
        Mismatch(s.str());
    }
    if (++seen_ % bruteEvery_ == 0) {
        ++c.bruteChecked;
        if (!SameHit(hit, geometry::IntersectBruteForce(scene_, r))) {
            ++c.bruteMismatches;
            Mismatch(kind + " " + Describe(ray) + ": differs from geometry::IntersectBruteForce");
        }
    }
}

void HitOracle::CheckOccluded(const RcRay& ray, bool blocked) {
    if (ray.direction.x == 0.0f && ray.direction.y == 0.0f && ray.direction.z == 0.0f) return;
    Tally::Count& c = tally_.byKind["shadow"];
    const geometry::Ray<float> r = HostRay(ray);
    uint64_t tests = 0;
    const bool want = bvh_.Occluded(r, tests);
    ++c.rays;
    c.hits += want;
    if (blocked != want) {
        ++c.mismatches;
        Mismatch("shadow " + Describe(ray) + ": query says " + (blocked ? "blocked" : "free"));
    }
    if (++seen_ % bruteEvery_ == 0) {
        ++c.bruteChecked;
        if (blocked != geometry::Occluded(scene_, r)) {
            ++c.bruteMismatches;
            Mismatch("shadow " + Describe(ray) + ": differs from geometry::Occluded");
        }
    }
}

namespace {

template <typename T>
std::vector<T> Read(clrt::Context& ctx, const cl::Buffer& b, size_t n) {
    std::vector<T> v(n);
    if (n) ctx.queue().enqueueReadBuffer(b, CL_TRUE, 0, n * sizeof(T), v.data());
    return v;
}

class Checked final : public render::RayQuery {
  public:
    Checked(clrt::Context& ctx, std::unique_ptr<render::RayQuery> inner, HitOracle& oracle)
        : ctx_(ctx), inner_(std::move(inner)), oracle_(oracle) {}

    std::string Name() const override { return inner_->Name(); }
    std::unique_ptr<render::PreparedBatch> Prepare(const cl::Buffer& rays, uint32_t n,
                                                   const cl::CommandQueue& queue,
                                                   const render::RaySource& source) override {
        return inner_->Prepare(rays, n, queue, source);
    }
    void Recycle(std::unique_ptr<render::PreparedBatch> batch) override {
        inner_->Recycle(std::move(batch));
    }
    render::QueryStats Stats() const override { return inner_->Stats(); }
    void BeginGeneration(uint32_t generation, const cl::Buffer& rays, uint32_t n,
                         render::KernelTimer& timer) override {
        inner_->BeginGeneration(generation, rays, n, timer);
    }
    void DescribeGeneration(render::GenerationStats& gen) const override {
        inner_->DescribeGeneration(gen);
    }
    void Reset() override { inner_->Reset(); }

    render::QueryResult Intersect(const cl::Buffer& rays, uint32_t n,
                                  const render::PreparedBatch* prepared, const cl::Buffer& hits,
                                  const render::ShadeBuffers& shade,
                                  render::KernelTimer& timer) override {
        const render::QueryResult result = inner_->Intersect(rays, n, prepared, hits, shade, timer);
        const std::vector<RcRay> r = Read<RcRay>(ctx_, rays, n);
        const std::vector<RcHit> h = Read<RcHit>(ctx_, hits, n);
        std::vector<RcRayInfo> info;
        if (shade.rayInfo()) info = Read<RcRayInfo>(ctx_, shade.rayInfo, n);
        for (uint32_t i = 0; i < n; ++i) {
            oracle_.CheckNearest(KindName(info.empty() ? RC_RAY_EYE : info[i].kind), r[i], h[i]);
        }
        return result;
    }

    uint64_t Occluded(const cl::Buffer& shadowRays, std::span<const RcRay> hostRays,
                      const cl::Buffer& blocked, render::KernelTimer& timer) override {
        const uint64_t tests = inner_->Occluded(shadowRays, hostRays, blocked, timer);
        const std::vector<uint8_t> b = Read<uint8_t>(ctx_, blocked, hostRays.size());
        for (size_t i = 0; i < hostRays.size(); ++i) oracle_.CheckOccluded(hostRays[i], b[i]);
        return tests;
    }

  private:
    clrt::Context& ctx_;
    std::unique_ptr<render::RayQuery> inner_;
    HitOracle& oracle_;
};

}  // namespace

std::unique_ptr<render::RayQuery> CheckedQuery(clrt::Context& ctx,
                                               std::unique_ptr<render::RayQuery> inner,
                                               HitOracle& oracle) {
    return std::make_unique<Checked>(ctx, std::move(inner), oracle);
}

std::vector<RcHit> CheckedEyeHits::FindHits(const scene::Scene& scene,
                                            const render::CameraBasis& camera,
                                            render::RenderStats& stats) {
    std::vector<RcHit> hits = inner_.FindHits(scene, camera, stats);
    const glm::vec3 o(camera.position);
    for (uint32_t y = 0; y < camera.height; ++y) {
        for (uint32_t x = 0; x < camera.width; ++x) {
            const glm::vec3 d = camera.DirectionFloat(x, y);
            const RcRay ray{{o.x, o.y, o.z, 0.0f}, {d.x, d.y, d.z, INFINITY}};
            oracle_.CheckNearest("eye", ray, hits[size_t(y) * camera.width + x]);
        }
    }
    return hits;
}

}  // namespace rayclass::proof
