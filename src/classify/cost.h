// The cost function: whether splitting a node's rays saves more list tests than the split costs,
// and which dimension to split. Private to the classify module.
#pragma once

#include <array>
#include <cstdint>

#include "lists.h"
#include "rayclass/classify/hierarchy.h"
#include "support.h"

namespace rayclass::classify {

class CostModel {
  public:
    // For the face roots of `sceneBox` (padded) over `scene`'s primitives.
    CostModel(const scene::Scene& scene, const Params& params, const Bounds3f& sceneBox);

    // Whether `node`, with `nRays` rays in bounds `tight` and candidate list `list`, is worth
    // splitting; then `dim` is the dimension to split. Lists of at most `minCandidates` entries
    // are not (Params::minCandidates, or lightMinCandidates for the light cells).
    bool ChooseSplit(const Node& node, const Bounds6& tight, uint32_t nRays, const ListView& list,
                     uint32_t minCandidates, int& dim) const;
    // The dimension to split by the extents of a node's interval (-1: none is long enough).
    int SplitDim(int face, const float* extent) const;

  private:
    double ListCost(const ListView& list) const;

    const Params& params_;
    std::array<float, kDims> rootExtent_[kFaceCount];
    bool trianglesOnly_;
    uint32_t sphereBase_, quadricBase_;
};

}  // namespace rayclass::classify
