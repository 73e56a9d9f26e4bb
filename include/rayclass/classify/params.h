// Parameters of the ray classification: the split strategy, the cost function that decides when a
// hypercube stops splitting, and the padding that keeps the candidate test conservative in float.
#pragma once

#include <cstdint>
#include <string>
#include <variant>

#include "rayclass/scene/scene.h"

namespace rayclass::classify {

enum class SplitRule : uint8_t {
    // Middle of the node's shrunk interval: one partition pass (default; see Params::splitRule).
    kMidpoint,
    // Median of the rays' coordinates: balanced children, but an nth_element per split.
    kMedian,
};

struct Params {
    // Split dimension: the largest extent relative to the face root's extent, the direction
    // extents (u, v) weighted by dirWeight. Split value: splitRule. Midpoint is the default
    // because it gave shorter mirror-ray lists than the median and classifies faster
    // (docs/bench/README.md, "Cost-function defaults").
    SplitRule splitRule = SplitRule::kMidpoint;
    float dirWeight = 1.0f;

    // A node filters a new candidate list every splitsPerList levels (and always as a leaf);
    // between them children share their parent's list, as Arvo & Kirk suggest for children of
    // one-dimension splits, which overlap heavily.
    int splitsPerList = 1;

    // Cost function. A leaf with R >= 2 rays and candidates of summed intersection cost C (ns per
    // ray) is split when its list holds more than minCandidates entries, one of its extents
    // exceeds the minimum hypercube size, and the query time a split is expected to save,
    // R * C * splitGain, exceeds the split's own cost, 2 * nCandidates * boxTestCost (two child
    // lists) + R * rayMoveCost, plus, when R <= minRays, the cost of the extra under-filled leaf
    // it makes: minRays * 16 * triangleCost (a work-group's first block of 16 candidates). So
    // groups above minRays split on the cost function alone and smaller ones only for long lists
    // (with the defaults a 16-ray group needs about 260 candidates, a 2-ray group about 2,400),
    // instead of a hard gate that left small groups with lists of 100k+ candidates.
    //
    // Per-test costs in ns on one core, as bench/classify/intersect_bench measures them (scalar
    // float routines of geometry/intersect.h, one ray against many random primitives; the list
    // filter per box) and classify_bench's partition time per ray and level for the ray move
    // (docs/bench/README.md, "Cost-function defaults"). Only the ratios matter to the decision.
    uint32_t minRays = 64;        // a work-group's worth of rays: smaller leaves cost extra
    uint32_t minCandidates = 16;  // the device tests 16 candidates at once: fewer gain nothing
    // minCandidates of the light cells' shadow rays (light_cells.h), whose leaves the device
    // answers by packets of 16 rays that test one candidate at a time: each candidate a shorter
    // list drops is a test saved.
    uint32_t lightMinCandidates = 8;
    float triangleCost = 13.9f;
    float sphereCost = 5.2f;
    float quadricCost = 12.4f;
    float boxTestCost = 0.45f;
    float rayMoveCost = 1.0f;
    float splitGain = 0.25f;  // fraction of a list a split is expected to drop per child
    int maxDepth = 60;

    // Kernel style auto's price of a vertex-style leaf's candidate block beyond its rays' tests:
    // the gather kernel's copy of the block's triangles, in fragment-packet iterations
    // (render/classified_query.cpp). Negative: the device's default, 13 on CPU devices
    // (measured with PoCL, where it leaves every leaf to the fragment style) and 0 on others
    // (not measured on a GPU yet).
    float vertexGatherCost = -1.0f;

    // Threads that subdivide a generation (0: one per core, or one for fewer than 32k rays).
    // The result does not depend on it.
    uint32_t threads = 0;
    // A node with more rays than this queues its later children as tasks for the threads
    // (0: max(32768, rays / 32)). The result does not depend on it either, except for node ids.
    uint32_t taskRays = 0;
    // A node with at least this many rays plans its next levels of midpoint splits at once
    // (halving its interval up to 4 times) and puts its rays into the plan's cells in one pass,
    // instead of moving every ray once per level (0: never; only with the midpoint rule).
    // The top levels of a generation then stream the rays through memory once: below about
    // 64k rays a node's rays stay in the core's cache and single splits cost less.
    uint32_t planRays = 65536;
    // Any-hit rays that all end at common points (shadow rays to point lights inside the scene
    // box) are sorted by cell of their direction from the point, on a grid of lightCells x
    // lightCells cells on each face of the direction cube, and the hierarchy splits ranges of
    // cells instead of moving rays (src/classify/light_cells.h). A power of two from 4 to 256;
    // 0: never (such rays take the general path), -1: chosen from the number of rays.
    int lightCells = -1;

    // Minimum hypercube size: a dimension is split only while its extent exceeds this fraction of
    // the face root's extent (scene box side for X, Y, Z; 2 for u, v). Below it the nearest
    // objects usually cover the whole beam and the distance optimisation ends queries anyway.
    float minOriginFraction = 1.0f / 4096.0f;
    float minDirFraction = 1.0f / 4096.0f;

    // Primitive and scene boxes grow by this much on every side (world units) so that rounding in
    // the float candidate test never drops a primitive a ray hits. Scene-scaled: 2e-6 * diagonal
    // is about 16 ulps of the largest coordinate, far above the test's rounding error.
    float padding = 0.0f;

    // Defaults for `scene`: the padding from its diagonal.
    static Params ForScene(const scene::Scene& scene);
};

// One cost-function setting, parsed: a field of Params and the value it takes. The command line
// parses `--classify NAME=VALUE` into one of these once; whoever builds the Params applies it.
struct ParamSetting {
    template <typename T>
    struct Field {
        T Params::*member;
        T value;
    };
    std::variant<Field<uint32_t>, Field<int>, Field<float>, Field<SplitRule>> field;

    void ApplyTo(Params& params) const {
        std::visit([&params](const auto& f) { params.*f.member = f.value; }, field);
    }
};

// Parses one parameter by its command-line name (`--classify NAME=VALUE`):
//   min-rays N, min-candidates N, splits-per-list N (N >= 1), split midpoint|median,
//   min-origin-fraction F, min-dir-fraction F (0 <= F <= 1), dir-weight W (W > 0),
//   threads N (0: one per core), task-rays N (0: automatic), plan-rays N (0: never),
//   light-cells auto|off|N (N a power of two from 4 to 256), vertex-gather F (F >= 0).
// Throws rayclass::UsageError naming the valid names or values when `name` is unknown or `value`
// does not parse completely or is out of range.
ParamSetting ParseParam(const std::string& name, const std::string& value);

// ParseParam(name, value) applied to `params`, for programs that set a parameter once.
void SetParam(Params& params, const std::string& name, const std::string& value);

// The names ParseParam accepts, comma-separated, for help texts.
const char* ParamNames();

}  // namespace rayclass::classify
