// The hit-exact check's oracle and its taps into a render. Every nearest hit and every shadow
// answer a render's query gives (and every eye hit of the raster pass) is compared with brute
// force in float, the kernels' arithmetic: through render::ReferenceBvh, whose float answers
// equal geometry::IntersectBruteForce<float> and geometry::Occluded<float> exactly
// (tests/render/reference_bvh_test.cpp), so that every ray can be checked; a sample of rays is
// also compared with brute force itself.
#pragma once

#include <array>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "rayclass/clrt/context.h"
#include "rayclass/render/device_scene.h"
#include "rayclass/render/eye_hits.h"
#include "rayclass/render/ray_query.h"
#include "rayclass/render/reference_bvh.h"
#include "rayclass/scene/scene.h"

namespace rayclass::proof {

// Rays checked and mismatches, per ray kind ("eye", "reflection", "refraction", "shadow").
struct Tally {
    struct Count {
        uint64_t rays = 0, hits = 0, mismatches = 0, bruteChecked = 0, bruteMismatches = 0;
    };
    std::map<std::string, Count> byKind;
    std::vector<std::string> firstMismatches;  // up to 10, described

    uint64_t Mismatches() const;
    std::string Summary() const;
};

class HitOracle {
  public:
    // Every `bruteEvery`-th ray is also answered by brute force.
    HitOracle(const scene::Scene& scene, uint32_t bruteEvery);

    void CheckNearest(const std::string& kind, const RcRay& ray, const RcHit& hit);
    // Empty shadow slots (no direction) are skipped: they miss by construction.
    void CheckOccluded(const RcRay& ray, bool blocked);

    Tally& tally() { return tally_; }

  private:
    void Mismatch(const std::string& what);

    const scene::Scene& scene_;
    render::ReferenceBvh bvh_;
    uint32_t bruteEvery_;
    uint64_t seen_ = 0;
    Tally tally_;
};

// The renderer's query with every answer checked: forwards every call to `inner`, then reads
// the batch's rays, hits and ray kinds back and hands them to `oracle`.
std::unique_ptr<render::RayQuery> CheckedQuery(clrt::Context& ctx,
                                               std::unique_ptr<render::RayQuery> inner,
                                               HitOracle& oracle);

// An eye-hit source whose every hit is checked against the eye ray rc_generate_eye_rays makes.
class CheckedEyeHits final : public render::EyeHitSource {
  public:
    CheckedEyeHits(render::EyeHitSource& inner, HitOracle& oracle)
        : inner_(inner), oracle_(oracle) {}
    std::string Name() const override { return inner_.Name(); }
    std::vector<RcHit> FindHits(const scene::Scene& scene, const render::CameraBasis& camera,
                                render::RenderStats& stats) override;

  private:
    render::EyeHitSource& inner_;
    HitOracle& oracle_;
};

}  // namespace rayclass::proof
