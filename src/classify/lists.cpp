#include "lists.h"

#include <algorithm>
#include <thread>
#include <vector>

#include "filter.h"
#include "rayclass/core/radix_sort.h"
#include "support.h"

namespace rayclass::classify {

namespace {

// Scenes smaller than this sort their face lists on one thread: starting threads costs more.
constexpr uint32_t kParallelSortMin = 16384;

// The primitives' boxes, padded.
std::vector<Bounds3f> PaddedBoxes(const scene::Scene& scene, float padding, int threads) {
    const uint32_t nPrims = scene.PrimitiveCount();
    std::vector<Bounds3f> boxes(nPrims);
    OnThreads(threads, [&](int t) {
        const uint32_t step = (nPrims + uint32_t(threads) - 1) / uint32_t(threads);
        const uint32_t end = std::min(nPrims, uint32_t(t) * step + step);
        for (uint32_t id = uint32_t(t) * step; id < end; ++id) {
            boxes[id] = scene.PrimitiveBounds(id);
            boxes[id].lo -= glm::vec3(padding);
            boxes[id].hi += glm::vec3(padding);
        }
    });
    return boxes;
}

// A thread's arrays, reused from face to face: fresh ones cost their page faults again.
struct SortScratch {
    std::vector<float> key;
    std::vector<uint32_t> order;
    RadixScratch sort;
};

// Face `face`'s list of `boxes`, whose union is `all`.
void BuildFace(int face, const std::vector<Bounds3f>& boxes, const Bounds3f& all, FaceLists& out,
               SortScratch& scratch) {
    const uint32_t nPrims = uint32_t(boxes.size());
    const Box5 frameBox = BoxInFace(face, all);
    const ListFrame& frame = out.frame[face] =
        MakeListFrame(frameBox.lo.data(), frameBox.hi.data());
    // The list in distance order: near side along the face's main axis, ties by id for
    // determinism.
    std::vector<float>& key = scratch.key;
    key.resize(nPrims);
    for (uint32_t id = 0; id < nPrims; ++id) key[id] = BoxInFace(face, boxes[id]).lo[0];
    std::vector<uint32_t>& order = scratch.order;
    SortedOrder(key, order, scratch.sort);
    // The boxes in list order, each read once: gathering six step arrays by the order cost six
    // random reads an entry.
    FaceList& l = out.list[face];
    l.Resize(nPrims);
    FillFaceList(face, frame, boxes.data(), order.data(), nPrims, Out(l, 0));
    if (!FilterSkipsBlocks()) return;
    FaceList& blocks = out.blocks[face];
    blocks.Resize(BlockCount(nPrims));
    FillBlocks(View(l, nPrims, &frame), Out(blocks, 0));
}

}  // namespace

void FaceList::Resize(size_t n) {
    for (auto* a : {&x0, &x1, &y0, &y1, &z0, &z1}) Regrow(*a, n);
    Regrow(prim, n);
}

size_t FaceLists::Bytes() const {
    size_t bytes = 0;
    for (const FaceList& l : list) bytes += l.Bytes();
    for (const FaceList& b : blocks) bytes += b.Bytes();
    return bytes;
}

std::shared_ptr<const FaceLists> BuildFaceLists(const scene::Scene& scene, const Params& params) {
    const int threads = scene.PrimitiveCount() < kParallelSortMin
                            ? 1
                            : int(std::clamp(std::thread::hardware_concurrency(), 1u, 6u));
    const std::vector<Bounds3f> boxes = PaddedBoxes(scene, params.padding, threads);
    // A face's frame permutes and negates the world axes, so the union of its boxes is the
    // union of the world boxes in its frame, and its sort key (the near X) is a world bound.
    Bounds3f all;
    for (const Bounds3f& b : boxes) all.Grow(b);
    auto lists = std::make_shared<FaceLists>();
    OnThreads(threads, [&](int t) {
        SortScratch scratch;
        for (int face = t; face < kFaceCount; face += threads) {
            BuildFace(face, boxes, all, *lists, scratch);
        }
    });
    return lists;
}

}  // namespace rayclass::classify
