// The ray query that picks, generation by generation, between the ray classification and the BVH
// (--accel auto) for nearest hits. Coherent generations (eye rays, first bounces) are the
// classification's; as rays scatter, its host work grows with every bounce, while the BVH's cost
// per ray grows far less, so on deep mirror bounces the BVH wins. Each generation, the BVH
// answers a sample of the new rays; when that costs less per ray (in process CPU time on a CPU
// device, CostInProcessCpuTime) than the classification is predicted to (from the last two
// generations it answered), the BVH answers this generation and every later one: the
// classification, measured on the less scattered rays of earlier generations, has no cost to
// compare a BVH generation with, and one it took back cost several times the BVH's. Shadow rays
// stay classified from their light, where they stay coherent however scattered their origins, while
// the BVH's beam walk loses its coherence with them. Both answer every ray exactly alike (the same
// primitive routines), so the choice changes the time, never the image.
#pragma once

#include <algorithm>
#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "rayclass/render/ray_query.h"

namespace rayclass::render {

// The CPU seconds all the process's threads have run, PoCL's workers among them. Wall time also
// counts the stretches the machine's other work holds the cores, which a whole generation suffers
// in full while a sample of a few ms often escapes them, so on a loaded machine a wall-time
// comparison followed the load rather than the methods.
double ProcessCpuSeconds();

// Whether both methods' costs are read on ProcessCpuSeconds for a device of `type`: only a CPU
// device runs its kernels on the process's threads. A GPU's kernels take no CPU time of the
// process, so there a cost in CPU time would leave out the device's work and the costs are wall
// seconds.
bool CostInProcessCpuTime(cl_device_type type);

// The classification's time on the render thread over a generation's batches.
struct ClassifiedTimes {
    double wall = 0;     // wall seconds
    double cost = 0;     // the same stretches on the cost clock (CostInProcessCpuTime)
    double shading = 0;  // the wall seconds of the shading kernel among them
    // The cost less the shading's, which the BVH leaves to the renderer after its query:
    // shading's share of the wall time, as the kernel's own CPU time is not measured.
    double QuerySeconds() const;
};

// Cost per ray in seconds of the cost clock (CostInProcessCpuTime) of the two ways to answer
// nearest-hit queries, and the rule that picks the BVH.
struct QueryCosts {
    double classified = 0;        // the classification's, on the last generation it answered
    double classifiedBefore = 0;  // and on the one before that (0: not measured)
    double bvhSample = 0;         // the BVH's on a sample of this generation's rays

    // The classification's cost on this generation if it grows by the factor it grew by on the
    // last (rays scatter further with each bounce), bounded to [1, 2] (a wider bound let one noisy
    // generation switch too early).
    double PredictedClassified() const {
        const double growth = classifiedBefore > 0 ? classified / classifiedBefore : 1.0;
        return classified * std::clamp(growth, 1.0, 2.0);
    }
    // True when the BVH should take this generation and the later ones over: both were measured
    // and its sample cost less.
    bool PreferBvh() const {
        return classified > 0 && bvhSample > 0 && bvhSample < PredictedClassified();
    }
};

// The BVH's sample of a generation's first batch `rays`: kSampleGroups groups of kSampleRuns runs
// of kSampleRunRays consecutive rays, the runs spread evenly over `rays` and dealt to the groups
// in turn; shorter runs where the sample would be more than a kSampleShare-th of `rays` (it is
// paid on top of the generation), and one group of all of them where runs would be empty. Runs,
// because neighbouring rays share the tree's paths through the cache: a sample of single rays
// spread as evenly came out dearer per ray than whole generations. Disjoint groups, each answered
// once, because a group answered again finds exactly the nodes it needs in the cache, which a
// generation's rays do not: the auto query takes the cheapest group.
constexpr size_t kSampleGroups = 3, kSampleRuns = 16, kSampleRunRays = 1024, kSampleShare = 4;
std::vector<std::vector<RcRay>> PickBvhSample(std::span<const RcRay> rays);

// `classified` and the query `makeBvh` makes answer the same scene; the BVH is made when the
// first sample needs it, so a render without secondary rays never builds it.
std::unique_ptr<RayQuery> MakeAutoQuery(clrt::Context& ctx, std::unique_ptr<RayQuery> classified,
                                        std::function<std::unique_ptr<RayQuery>()> makeBvh);

}  // namespace rayclass::render
