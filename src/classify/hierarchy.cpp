// The hierarchy's facade: the shared core, the generation being inserted, and the strategy that
// classifies it.
#include "rayclass/classify/hierarchy.h"

#include "core.h"
#include "light_cells.h"
#include "pinhole.h"
#include "ray_subdivision.h"

namespace rayclass::classify {

struct Hierarchy::Impl {
    explicit Impl(const scene::Scene& scene, const Params& params) : core(scene, params) {}
    explicit Impl(const Impl& other) : core(other.core) {}

    Core core;
    Generation generation;
    RaySubdivision rays{core};
    PinholeSubdivision pinhole{core};
    LightCellSubdivision lightCells{core};
};

Hierarchy::Hierarchy(const scene::Scene& scene, const Params& params)
    : impl_(std::make_unique<Impl>(scene, params)) {}

Hierarchy::Hierarchy(const Hierarchy& other) : impl_(std::make_unique<Impl>(*other.impl_)) {}

Hierarchy::~Hierarchy() = default;

void Hierarchy::Insert(RayView rays, RayUse use) {
    const Core& core = impl_->core;
    Generation::Inserted in{rays, {}};
    if (use == RayUse::kAnyHit && !core.sceneBox.Empty()) {
        in.ends = FindCommonEnds(rays, core.sceneBox, 0.25f * core.params.padding);
    }
    impl_->generation.inserted.push_back(in);
    impl_->generation.n += uint32_t(rays.size());
}

void Hierarchy::Subdivide(LeafBatch& out) {
    Impl& h = *impl_;
    h.core.counters = {};
    // rayIndex is resized, not cleared, by the strategies: every slot is written again.
    out.leaves.clear();
    out.missed.clear();
    out.nRays = h.generation.n;
    if (!h.lightCells.Classify(h.generation, out)) h.rays.Classify(h.generation, out);
    h.generation.Clear();
}

LeafBatch Hierarchy::Subdivide() {
    LeafBatch out;
    Subdivide(out);
    return out;
}

void Hierarchy::Classify(RayView rays, LeafBatch& out, RayUse use) {
    Insert(rays, use);
    Subdivide(out);
}

LeafBatch Hierarchy::Classify(RayView rays, RayUse use) {
    Insert(rays, use);
    return Subdivide();
}

bool Hierarchy::ClassifyPinhole(const RcCamera& camera, uint32_t first, uint32_t n,
                                LeafBatch& out) {
    if (!impl_->generation.inserted.empty()) return false;
    return impl_->pinhole.Classify(camera, first, n, out);
}

void Hierarchy::Reset() { impl_->core.Reset(); }

const std::vector<Node>& Hierarchy::Nodes() const { return impl_->core.nodes; }

uint32_t Hierarchy::Route(const Ray5& r) const { return impl_->core.Route(r); }

const BuildCounters& Hierarchy::Counters() const { return impl_->core.counters; }

const Params& Hierarchy::GetParams() const { return impl_->core.params; }

const Bounds3f& Hierarchy::SceneBox() const { return impl_->core.sceneBox; }

size_t Hierarchy::MemoryBytes() const { return impl_->core.MemoryBytes(); }

}  // namespace rayclass::classify
