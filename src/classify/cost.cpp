#include "cost.h"

#include <algorithm>

namespace rayclass::classify {

CostModel::CostModel(const scene::Scene& scene, const Params& params, const Bounds3f& sceneBox)
    : params_(params),
      trianglesOnly_(scene.spheres.empty() && scene.quadrics.empty()),
      sphereBase_(scene.SphereBase()),
      quadricBase_(scene.QuadricBase()) {
    for (int face = 0; face < kFaceCount; ++face) {
        const Box5 root = BoxInFace(face, sceneBox);
        for (int k = 0; k < kDims; ++k) {
            rootExtent_[face][k] = std::max(root.hi[k] - root.lo[k], 0.0f);
        }
    }
}

double CostModel::ListCost(const ListView& list) const {
    const Params& p = params_;
    if (trianglesOnly_) return double(list.n) * p.triangleCost;
    double cost = 0.0;
    for (size_t i = 0; i < list.n; ++i) {
        const uint32_t id = list.prim[i];
        cost +=
            id < sphereBase_ ? p.triangleCost : (id < quadricBase_ ? p.sphereCost : p.quadricCost);
    }
    return cost;
}

bool CostModel::ChooseSplit(const Node& node, const Bounds6& tight, uint32_t nRays,
                            const ListView& list, uint32_t minCandidates, int& dim) const {
    const Params& p = params_;
    if (nRays < 2 || list.n <= minCandidates || node.depth >= p.maxDepth) return false;
    const double saved = double(nRays) * ListCost(list) * p.splitGain;
    double cost = 2.0 * double(list.n) * p.boxTestCost + double(nRays) * p.rayMoveCost;
    // Below minRays the split also pays for the leaf it adds: the device runs each leaf as a
    // work-group, and one that is not full still costs about what a full one's first candidate
    // block does. So small groups split only for long lists, as long as the cost function says.
    if (nRays <= p.minRays) cost += double(p.minRays) * 16.0 * p.triangleCost;
    // The dimension last: its divisions are wasted on the nodes the cost leaves whole.
    if (!(saved > cost)) return false;
    float extent[kDims];
    for (int k = 0; k < kDims; ++k) extent[k] = tight.hi[k] - tight.lo[k];
    dim = SplitDim(node.face, extent);
    return dim >= 0;
}

int CostModel::SplitDim(int face, const float* extent) const {
    const Params& p = params_;
    float best = 0.0f;
    int dim = -1;
    for (int k = 0; k < kDims; ++k) {
        const float root = rootExtent_[face][k];
        const bool isDir = k >= 3;
        const float minExtent = root * (isDir ? p.minDirFraction : p.minOriginFraction);
        if (!(extent[k] > minExtent)) continue;
        const float rel = extent[k] / root * (isDir ? p.dirWeight : 1.0f);
        if (rel > best) {
            best = rel;
            dim = k;
        }
    }
    return dim;
}

}  // namespace rayclass::classify
