#include "rayclass/accel/kdtree.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <future>
#include <stdexcept>
#include <thread>

#include "rayclass/accel/triangle_box.h"

namespace rayclass::accel {

namespace {

// Where a primitive's (padded) extent in a node ends or starts along one axis. A node's events
// stay sorted by axis, then position, then ends before starts: each axis' sweep is one pass.
struct Event {
    float pos;
    uint32_t prim;
    uint8_t axis;
    uint8_t start;  // 0: the extent ends here, 1: it starts here
};

bool Before(const Event& a, const Event& b) {
    if (a.axis != b.axis) return a.axis < b.axis;
    if (a.pos != b.pos) return a.pos < b.pos;
    return a.start < b.start;
}

float Down(double x) {
    const float f = float(x);
    return double(f) > x ? std::nextafter(f, -INFINITY) : f;
}

float Up(double x) {
    const float f = float(x);
    return double(f) < x ? std::nextafter(f, INFINITY) : f;
}

double HalfArea(const Bounds3d& b) {
    const glm::dvec3 s = b.hi - b.lo;
    return s.x * s.y + s.y * s.z + s.z * s.x;
}

enum class Side : uint8_t { kBoth, kLower, kUpper };

struct Split {
    double cost = INFINITY;
    int axis = -1;
    float pos = 0;
};

// A subtree in the final layout relative to its own start: node indices and primitive index
// positions count from 0.
struct Fragment {
    std::vector<RcKdNode> nodes;
    std::vector<uint32_t> primIndex;
    uint32_t maxDepth = 0, leaves = 0, emptyLeaves = 0;

    // Appends `f`, moving its node indices and primitive positions past what is here.
    void Append(const Fragment& f) {
        const uint32_t nodeBase = uint32_t(nodes.size()), primBase = uint32_t(primIndex.size());
        for (RcKdNode node : f.nodes) {
            if ((node.word & 3u) == RC_KD_LEAF) {
                node.data += primBase;
            } else {
                node.word += nodeBase << 2;
            }
            nodes.push_back(node);
        }
        primIndex.insert(primIndex.end(), f.primIndex.begin(), f.primIndex.end());
        maxDepth = std::max(maxDepth, f.maxDepth);
        leaves += f.leaves;
        emptyLeaves += f.emptyLeaves;
    }
};

struct Builder {
    const scene::Scene& scene;
    KdBuildParams params;
    double pad;
    uint32_t maxDepth;
    uint32_t parallelDepth;  // subtrees above it build on threads of their own

    // The events of `prim`'s extent in `box`, padded; none when the primitive misses the box.
    void AddEvents(uint32_t prim, const Bounds3d& box, std::vector<Event>& out) const {
        const Bounds3d e = Padded(PrimitiveExtentIn(scene, prim, Padded(box, pad)), pad);
        if (e.Empty()) return;
        for (uint8_t axis = 0; axis < 3; ++axis) {
            out.push_back({Down(e.lo[axis]), prim, axis, 1});
            out.push_back({Up(e.hi[axis]), prim, axis, 0});
        }
    }

    // The cheapest plane by the SAH, one sweep per axis over the node's sorted events.
    Split FindSplit(const std::vector<Event>& events, const Bounds3d& box, uint32_t n) const {
        const double area = HalfArea(box);
        Split best;
        size_t i = 0;
        while (i < events.size()) {
            const uint8_t axis = events[i].axis;
            uint32_t below = 0, above = n;
            while (i < events.size() && events[i].axis == axis) {
                const float pos = events[i].pos;
                uint32_t ending = 0, starting = 0;
                for (; i < events.size() && events[i].axis == axis && events[i].pos == pos; ++i) {
                    (events[i].start ? starting : ending) += 1;
                }
                above -= ending;
                if (pos > box.lo[axis] && pos < box.hi[axis]) {
                    Bounds3d lower = box, upper = box;
                    lower.hi[axis] = upper.lo[axis] = pos;
                    double cost = params.traversalCost +
                                  params.intersectCost *
                                      (HalfArea(lower) * below + HalfArea(upper) * above) / area;
                    if (below == 0 || above == 0) cost *= 1.0 - params.emptyBonus;
                    if (cost < best.cost) best = {cost, axis, pos};
                }
                below += starting;
            }
        }
        return best;
    }

    static void Leaf(Fragment& out, uint32_t self, const std::vector<Event>& events) {
        const uint32_t first = uint32_t(out.primIndex.size());
        for (const Event& e : events) {
            if (e.axis == 0 && e.start) out.primIndex.push_back(e.prim);
        }
        std::sort(out.primIndex.begin() + first, out.primIndex.end());
        const uint32_t count = uint32_t(out.primIndex.size()) - first;
        out.nodes[self] = {count << 2 | RC_KD_LEAF, first};
        ++out.leaves;
        out.emptyLeaves += count == 0;
    }

    // The events of one side of the split: those of the primitives only on it, merged with the
    // events of the primitives on both sides clipped to its cell.
    std::vector<Event> ChildEvents(const std::vector<Event>& events, const std::vector<Side>& side,
                                   const std::vector<uint32_t>& straddling, Side only,
                                   const Bounds3d& cell) const {
        std::vector<Event> kept, clipped;
        kept.reserve(events.size());
        clipped.reserve(6 * straddling.size());
        for (const Event& e : events) {
            if (side[e.prim] == only) kept.push_back(e);
        }
        for (uint32_t prim : straddling) AddEvents(prim, cell, clipped);
        std::sort(clipped.begin(), clipped.end(), Before);
        std::vector<Event> out(kept.size() + clipped.size());
        std::merge(kept.begin(), kept.end(), clipped.begin(), clipped.end(), out.begin(), Before);
        return out;
    }

    // Builds the subtree of `box` into `out`; `side` is scratch of one entry per primitive.
    void Node(std::vector<Event> events, const Bounds3d& box, uint32_t depth, Fragment& out,
              std::vector<Side>& side) const {
        const uint32_t self = uint32_t(out.nodes.size());
        out.nodes.push_back({});
        out.maxDepth = std::max(out.maxDepth, depth);
        uint32_t n = 0;
        for (const Event& e : events) n += e.axis == 0 && e.start;
        const Split split = n == 0 || depth >= maxDepth ? Split{} : FindSplit(events, box, n);
        if (split.axis < 0 || split.cost >= params.intersectCost * n) {
            return Leaf(out, self, events);
        }

        // Extents ending at the plane lie below it, extents starting there above it, as the
        // sweep counted them.
        std::vector<uint32_t> straddling;
        for (const Event& e : events) {
            if (e.axis == 0 && e.start) side[e.prim] = Side::kBoth;
        }
        for (const Event& e : events) {
            if (e.axis != split.axis) continue;
            if (!e.start && e.pos <= split.pos) side[e.prim] = Side::kLower;
            if (e.start && e.pos >= split.pos) side[e.prim] = Side::kUpper;
        }
        for (const Event& e : events) {
            if (e.axis == 0 && e.start && side[e.prim] == Side::kBoth) straddling.push_back(e.prim);
        }
        Bounds3d lower = box, upper = box;
        lower.hi[split.axis] = upper.lo[split.axis] = split.pos;
        std::vector<Event> lowerEvents = ChildEvents(events, side, straddling, Side::kLower, lower);
        std::vector<Event> upperEvents = ChildEvents(events, side, straddling, Side::kUpper, upper);
        events = {};
        straddling = {};
        if (depth < parallelDepth) {
            // The lower subtree on a thread of its own, the upper one here, then both after
            // this node in depth-first order.
            Fragment lowerPart, upperPart;
            auto lowerDone = std::async(std::launch::async, [&] {
                std::vector<Side> own(side.size(), Side::kBoth);
                Node(std::move(lowerEvents), lower, depth + 1, lowerPart, own);
            });
            Node(std::move(upperEvents), upper, depth + 1, upperPart, side);
            lowerDone.get();
            out.Append(lowerPart);
            const uint32_t upperIndex = uint32_t(out.nodes.size());
            out.Append(upperPart);
            out.nodes[self] = {upperIndex << 2 | uint32_t(split.axis),
                               std::bit_cast<uint32_t>(split.pos)};
            return;
        }
        Node(std::move(lowerEvents), lower, depth + 1, out, side);
        const uint32_t upperIndex = uint32_t(out.nodes.size());
        Node(std::move(upperEvents), upper, depth + 1, out, side);
        out.nodes[self] = {upperIndex << 2 | uint32_t(split.axis),
                           std::bit_cast<uint32_t>(split.pos)};
    }
};

}  // namespace

KdTree BuildKdTree(const scene::Scene& scene, const KdBuildParams& params) {
    KdTree tree;
    const uint32_t n = scene.PrimitiveCount();
    const Bounds3f sceneBox = scene.Bounds();
    const double pad = sceneBox.Empty() ? 1e-6 : 1e-6 * double(sceneBox.Diagonal()) + 1e-30;
    tree.pad = float(pad);
    Bounds3d root{glm::dvec3(0.0), glm::dvec3(0.0)};
    if (!sceneBox.Empty()) root = {glm::dvec3(sceneBox.lo), glm::dvec3(sceneBox.hi)};
    root = Padded(root, 2 * pad);
    root.lo = {Down(root.lo.x), Down(root.lo.y), Down(root.lo.z)};
    root.hi = {Up(root.hi.x), Up(root.hi.y), Up(root.hi.z)};
    tree.box = {glm::vec3(root.lo), glm::vec3(root.hi)};
    const uint32_t depthRule = uint32_t(8 + 1.5 * std::log2(std::max(1u, n)));
    // Two subtrees a thread until every hardware thread has about two to build.
    const uint32_t threads = std::max(1u, std::thread::hardware_concurrency());
    const Builder b{scene, params, pad,
                    std::min(params.maxDepth ? params.maxDepth : depthRule, kKdMaxDepth - 1),
                    uint32_t(std::bit_width(threads))};
    std::vector<Event> events;
    events.reserve(size_t(6) * n);
    for (uint32_t prim = 0; prim < n; ++prim) b.AddEvents(prim, root, events);
    std::sort(events.begin(), events.end(), Before);
    Fragment built;
    std::vector<Side> side(n, Side::kBoth);
    b.Node(std::move(events), root, 0, built, side);
    tree.nodes = std::move(built.nodes);
    tree.primIndex = std::move(built.primIndex);
    tree.maxDepth = built.maxDepth;
    tree.leaves = built.leaves;
    tree.emptyLeaves = built.emptyLeaves;
    if (tree.primIndex.size() >= (1ull << 30)) {
        throw std::runtime_error("kdtree: more primitive references than a leaf can address");
    }
    return tree;
}

}  // namespace rayclass::accel
