#include "light_cones.h"

#include <algorithm>
#include <cmath>

#include "filter.h"

namespace rayclass::classify {

namespace {

// Where cone (prefix, depth) lies in its face's heap.
constexpr size_t HeapIndex(uint32_t prefix, int depth) { return (size_t(1) << depth) - 1 + prefix; }
constexpr size_t kHeapSize = HeapIndex(0, LightCones::kDepth + 1);

// A point's cones hold for points this close to it (each coordinate): FindCommonEnds places a
// light's point within a quarter of the padding of the true one, so two generations' points lie
// this close.
float ReuseRadius(const Params& params) { return 0.5f * params.padding; }

// The beam of cone (prefix, depth) of `face` from every point within r of `point`: the
// cells of the node's (u, v) range, out to the far side of `box`.
Bounds6 ConeBounds(const glm::vec3& point, float r, int face, uint32_t prefix, int depth,
                   const Bounds3f& box) {
    const int a = FaceAxis(face);
    const float origin[3] = {FaceX(face, point), point[(a + 1) % 3], point[(a + 2) % 3]};
    Bounds6 t;
    for (int k = 0; k < 3; ++k) {
        t.lo[k] = origin[k] - r;
        t.hi[k] = origin[k] + r;
    }
    // The key's bits from the top: u's, then v's, in turn.
    uint32_t cell[2] = {0, 0};
    for (int i = 0; i < depth; ++i) {
        cell[i % 2] = 2 * cell[i % 2] + ((prefix >> (depth - 1 - i)) & 1u);
    }
    for (int k = 0; k < 2; ++k) {
        const float size = 2.0f / float(1u << ((depth + 1 - k) / 2));
        t.lo[3 + k] = float(cell[k]) * size - 1.0f - kCellPad;
        t.hi[3 + k] = float(cell[k] + 1) * size - 1.0f + kCellPad;
    }
    t.lo[kDims] = t.lo[0];
    t.hi[kDims] = BoxInFace(face, box).hi[0];
    return t;
}

}  // namespace

void LightCones::Use(const CommonEnds& ends) {
    const float r = ReuseRadius(core_.params);
    std::vector<std::unique_ptr<PointCones>> last = std::move(points_);
    points_.clear();
    points_.resize(size_t(ends.n));
    for (int k = 0; k < ends.n; ++k) {
        const glm::vec3& p = ends.point[size_t(k)];
        std::unique_ptr<PointCones>& pc = points_[size_t(k)];
        for (auto& kept : last) {
            if (!kept) continue;
            const glm::vec3 d = glm::abs(p - kept->point);
            if (std::max({d.x, d.y, d.z}) <= r) {
                pc = std::move(kept);
                break;
            }
        }
        if (pc) continue;
        pc = std::make_unique<PointCones>();
        pc->point = p;
        for (auto& cones : pc->cone) cones = std::make_unique<Cone[]>(kHeapSize);
    }
}

ListView LightCones::List(uint32_t root, uint32_t prefix, int depth, uint64_t& boxTests) {
    PointCones& pc = *points_[root / kFaceCount];
    const int face = int(root % kFaceCount);
    Cone& cone = pc.cone[face][HeapIndex(prefix, depth)];
    if (cone.ready.load(std::memory_order_acquire)) {
        return View(cone.list, cone.n, &core_.faceLists->frame[face]);
    }
    std::lock_guard lock(mutex_);
    return Fill(pc, face, prefix, depth, boxTests);
}

ListView LightCones::Fill(PointCones& pc, int face, uint32_t prefix, int depth,
                          uint64_t& boxTests) {
    Cone& cone = pc.cone[face][HeapIndex(prefix, depth)];
    const ListFrame* frame = &core_.faceLists->frame[face];
    if (cone.ready.load(std::memory_order_relaxed)) return View(cone.list, cone.n, frame);
    const ListView in = depth == 0 ? core_.faceLists->Whole(face)
                                   : Fill(pc, face, prefix >> 1, depth - 1, boxTests);
    const Bounds6 t =
        ConeBounds(pc.point, ReuseRadius(core_.params), face, prefix, depth, core_.sceneBox);
    scratch_.Resize(in.n);
    const size_t n =
        FilterList(MakeBeamTest(*frame, t.ToBox5(), t.hi[kDims] - t.lo[0]), in, Out(scratch_, 0));
    boxTests += in.n;
    cone.list.Resize(n);
    const ListView kept = View(scratch_, n, frame);
    const ListOut to = Out(cone.list, 0);
    std::copy_n(kept.x0, n, to.x0);
    std::copy_n(kept.x1, n, to.x1);
    std::copy_n(kept.y0, n, to.y0);
    std::copy_n(kept.y1, n, to.y1);
    std::copy_n(kept.z0, n, to.z0);
    std::copy_n(kept.z1, n, to.z1);
    std::copy_n(kept.prim, n, to.prim);
    cone.n = n;
    cone.ready.store(true, std::memory_order_release);
    return View(cone.list, n, frame);
}

size_t LightCones::Bytes() const {
    size_t bytes = scratch_.Bytes();
    for (const auto& pc : points_) {
        for (const auto& cones : pc->cone) {
            for (size_t i = 0; i < kHeapSize; ++i) bytes += cones[i].list.Bytes();
        }
    }
    return bytes;
}

}  // namespace rayclass::classify
