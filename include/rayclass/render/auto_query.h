// The ray query that picks, generation by generation, between the ray classification and the BVH
// (--accel auto). Coherent generations (eye rays, first bounces) are the classification's; as
// rays scatter, its host work grows with every bounce, while the BVH's cost per ray stays nearly
// flat, so on deep mirror bounces the BVH wins. Each generation, the BVH answers a sample of the
// new rays; when that costs less per ray than the classification is predicted to (from the last
// two generations it answered), the BVH answers this generation. A sample runs on rays and a tree
// the caches hold, and so costs less per ray than a whole generation: once the BVH has answered
// a generation, what that cost counts instead of any cheaper sample, and the classification
// takes the next generation back when the BVH cost more than it is predicted to (unless the
// classification was only measured on eye rays classified from their camera). Nearest-hit and
// shadow queries decide apart (shadow rays toward a point light stay coherent at their light's
// end), shadow queries only once the nearest-hit sample has built the BVH. Both answer every ray
// exactly alike (the same primitive routines), so the choice changes the time, never the image.
#pragma once

#include <algorithm>
#include <functional>
#include <memory>

#include "rayclass/render/ray_query.h"

namespace rayclass::render {

// Cost per ray in seconds of the two ways to answer a kind of query (nearest hit or shadow),
// and the rule that picks one.
struct QueryCosts {
    double classified = 0;        // the classification's, on the last generation it answered
    double classifiedBefore = 0;  // and on the one before that (0: not measured)
    double bvhSample = 0;         // the BVH's on a sample of this generation's rays
    double bvhMeasured = 0;       // the BVH's on the last generation it answered (0: none)
    // `classified` was measured on eye rays classified from their camera, unread: the cheapest
    // rays the classification answers, so a lower bound on a later generation's cost, not an
    // estimate of it.
    bool classifiedFromCamera = false;

    // The classification's cost on this generation if it grows by the factor it grew by on the
    // last (rays scatter further with each bounce), bounded to [1, 2] (a wider bound let one noisy
    // generation switch too early).
    double PredictedClassified() const {
        const double growth = classifiedBefore > 0 ? classified / classifiedBefore : 1.0;
        return classified * std::clamp(growth, 1.0, 2.0);
    }
    // True when the BVH should take a generation over: both were measured and the BVH cost less,
    // by its sample and by the last generation it answered.
    bool PreferBvh() const {
        return classified > 0 && bvhSample > 0 &&
               std::max(bvhSample, bvhMeasured) < PredictedClassified();
    }
    // True when the BVH, which answered the last generation, should keep the next one: it cost
    // no more than the classification is predicted to, or the classification was only measured
    // on eye rays from their camera: a BVH dearer than that bound may still be far cheaper than
    // the classification of the generation at hand, and on a loaded machine one slow generation
    // was enough to hand a deep bounce back to a classification that then cost several times as
    // much.
    bool KeepBvh() const { return classifiedFromCamera || bvhMeasured <= PredictedClassified(); }
};

// `classified` and the query `makeBvh` makes answer the same scene; the BVH is made when the
// first sample needs it, so a render without secondary rays never builds it.
std::unique_ptr<RayQuery> MakeAutoQuery(clrt::Context& ctx, std::unique_ptr<RayQuery> classified,
                                        std::function<std::unique_ptr<RayQuery>()> makeBvh);

}  // namespace rayclass::render
