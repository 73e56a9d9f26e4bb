// --stats on scenes with patches: how the patch boxes' Newton iteration ends. A sample of each
// nearest-hit batch's rays (evenly spaced; at most kSampleRays, and at most kSampleWork / boxes
// so that many boxes do not make the pass slow) is copied aside during the render; after it,
// rc_patch_newton_stats (cl/patch_stats.cl) tests every sampled ray against every patch box its
// segment enters, with the kernels' own iteration (rc_patch_box_newton), and counts its steps and
// how each test ended. The tests are those of a query that culls by the boxes alone, so the counts
// are the same under every --accel and --kernel.
#pragma once

#include <algorithm>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "rayclass/clrt/context.h"
#include "rayclass/render/buffers.h"
#include "rc_types.h"

namespace rayclass::render {

struct NewtonCounts {
    uint64_t rays = 0;   // rays tested
    uint64_t tests = 0;  // ray-box pairs whose box the ray's segment enters
    uint64_t steps = 0;  // Newton steps (updates of (u, v)) from the boxes' centres
    // How the search from the box's centre ended:
    uint64_t culled = 0;     // the ray missed the control points' hull: no step
    uint64_t converged = 0;  // |F| < eps (a hit, or a root outside the box or the segment)
    uint64_t diverged = 0;   // |F| grew
    uint64_t left = 0;       // (u, v) left the window around the box
    uint64_t onCap = 0;      // the iteration cap came first
    uint64_t hits = 0;       // converged inside the box's range and the segment
    // The tests that searched again from the box's quarters (the centre's did not converge),
    // those searches' Newton steps and how many of the tests hit.
    uint64_t restarted = 0, restartSteps = 0, restartHits = 0;

    // As --stats writes it (patch_newton): the counts and steps per test.
    std::map<std::string, double> ToStats() const;
};

// The counts of `rays` against the patch boxes of the analytic buffer (nAnalytic records).
NewtonCounts CountNewton(clrt::Context& ctx, const cl::Program& program, const SceneBuffers& scene,
                         uint32_t nAnalytic, const std::vector<RcRay>& rays);

class NewtonSampler {
  public:
    static constexpr uint32_t kSampleRays = 2048;
    static constexpr uint64_t kSampleWork = uint64_t(1) << 22;  // ray-box pairs a batch

    NewtonSampler(clrt::Context& ctx, const cl::Program& program, const SceneBuffers& scene,
                  uint32_t nAnalytic, size_t nBoxes)
        : ctx_(ctx),
          program_(program),
          scene_(scene),
          nAnalytic_(nAnalytic),
          sampleRays_(uint32_t(
              std::clamp<uint64_t>(kSampleWork / std::max<size_t>(nBoxes, 1), 1, kSampleRays))) {}

    // Enqueues, on ctx's queue after the kernels before it, a copy of the sample of rays[0, n).
    void Sample(const cl::Buffer& rays, uint32_t n);
    // Waits for the copies and counts the sample.
    NewtonCounts Count();

  private:
    clrt::Context& ctx_;
    const cl::Program& program_;
    const SceneBuffers& scene_;
    uint32_t nAnalytic_;
    uint32_t sampleRays_;                     // a batch's at most
    std::vector<std::vector<RcRay>> chunks_;  // one a batch; their storage stays put
};

}  // namespace rayclass::render
