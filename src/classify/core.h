// What the classification strategies share: the padded scene box, the node store with its six
// face roots, the presorted face lists, the cost function, the worker pool and the counters of
// the last generation; and the generation of rays inserted since. Private to the classify module.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "cost.h"
#include "lists.h"
#include "rayclass/classify/hierarchy.h"
#include "workers.h"

namespace rayclass::classify {

struct Core {
    Core(const scene::Scene& scene, const Params& params);
    // A core with `other`'s nodes that shares its face lists.
    explicit Core(const Core& other);
    Core& operator=(const Core&) = delete;

    const scene::Scene& scene;
    const Params params;
    const Bounds3f sceneBox;  // padded; empty when the scene is
    std::vector<Node> nodes;  // the face roots first
    const std::shared_ptr<const FaceLists> faceLists;
    const CostModel cost;
    WorkerPool pool;
    BuildCounters counters;

    // The leaf that routing `r` ends in (see Hierarchy::Route).
    uint32_t Route(const Ray5& r) const;
    // Back to the six face roots.
    void Reset();
    size_t MemoryBytes() const;
};

// The rays inserted since the last classification, as Insert took them.
struct Generation {
    struct Inserted {
        RayView rays;
        CommonEnds ends;  // none for nearest-hit rays
    };
    std::vector<Inserted> inserted;
    uint32_t n = 0;

    void Clear() {
        inserted.clear();
        n = 0;
    }
};

}  // namespace rayclass::classify
