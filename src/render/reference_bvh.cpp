#include "rayclass/render/reference_bvh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace rayclass::render {

namespace {

using V = glm::dvec3;
using Box = ReferenceBvh::Box;

constexpr int kBins = 16;
constexpr uint32_t kMaxLeaf = 4;
// Below this depth the surface area heuristic chooses splits; deeper, halves by count, so that
// the depth (and the traversal stack) stays bounded whatever the primitives.
constexpr uint32_t kSahDepth = 64;
constexpr int kStackSize = 128;

void Grow(Box& b, const V& p) {
    b.lo = glm::min(b.lo, p);
    b.hi = glm::max(b.hi, p);
}

void Grow(Box& b, const Box& o) {
    b.lo = glm::min(b.lo, o.lo);
    b.hi = glm::max(b.hi, o.hi);
}

double HalfArea(const Box& b) {
    const V e = glm::max(b.hi - b.lo, V(0.0));
    return e.x * e.y + e.y * e.z + e.z * e.x;
}

double MaxAbs(const Box& b) {
    const V m = glm::max(glm::abs(b.lo), glm::abs(b.hi));
    return std::max(m.x, std::max(m.y, m.z));
}

// The primitive's box in double, from its float data (exact) and a double radius.
Box PrimitiveBox(const scene::Scene& scene, uint32_t id) {
    Box b;
    if (id < scene.SphereBase()) {
        for (const glm::vec3& p : scene.triangles[id].p) Grow(b, V(p));
    } else if (id < scene.QuadricBase()) {
        const scene::Sphere& s = scene.spheres[id - scene.SphereBase()];
        Grow(b, V(s.center) - double(s.radius));
        Grow(b, V(s.center) + double(s.radius));
    } else if (id >= scene.PatchBoxBase()) {
        // The control points' box holds the surface (convex hull).
        const Bounds3f& c = scene.patchBoxes[id - scene.PatchBoxBase()].bounds;
        Grow(b, V(c.lo));
        Grow(b, V(c.hi));
    } else {
        const scene::Quadric& q = scene.quadrics[id - scene.QuadricBase()];
        Grow(b, V(q.boxMin));
        Grow(b, V(q.boxMax));
    }
    return b;
}

// Rounding in float moves a computed hit point by far less than 1e-4 of the coordinates involved
// (the primitive's and, through the ray origin, the scene's); the padding covers both.
std::vector<Box> PaddedPrimitiveBoxes(const scene::Scene& scene) {
    std::vector<Box> boxes(scene.PrimitiveCount());
    double sceneMax = 0.0;
    for (uint32_t id = 0; id < boxes.size(); ++id) {
        boxes[id] = PrimitiveBox(scene, id);
        sceneMax = std::max(sceneMax, MaxAbs(boxes[id]));
    }
    for (Box& b : boxes) {
        const double pad = 1e-4 * MaxAbs(b) + 1e-5 * sceneMax + 1e-300;
        b.lo -= pad;
        b.hi += pad;
    }
    return boxes;
}

// A ray's slab test against boxes. A zero direction component gives infinite slab distances (or
// NaN for an origin on the slab's plane, which the comparisons ignore: the box counts as entered).
struct Slabs {
    template <typename T>
    explicit Slabs(const geometry::Ray<T>& ray) : o(ray.o), tMin(double(ray.tMin)) {
        for (int a = 0; a < 3; ++a) {
            inv[a] = 1.0 / double(ray.d[a]);
            negative[a] = std::signbit(inv[a]);
        }
    }

    // Whether the ray enters `b` at a distance in [tMin, bound]; the entry distance in `tNear`.
    bool Enter(const Box& b, double bound, double& tNear) const {
        double t0 = tMin, t1 = bound;
        for (int a = 0; a < 3; ++a) {
            const double n = ((negative[a] ? b.hi[a] : b.lo[a]) - o[a]) * inv[a];
            const double f = ((negative[a] ? b.lo[a] : b.hi[a]) - o[a]) * inv[a];
            t0 = n > t0 ? n : t0;
            t1 = f < t1 ? f : t1;
        }
        tNear = t0;
        return t0 <= t1;
    }

    V o, inv;
    double tMin;
    bool negative[3];
};

}  // namespace

struct ReferenceBvh::Build {
    const std::vector<Box>& boxes;
    std::vector<V> centroids;
    std::vector<Node>& nodes;
    std::vector<uint32_t>& ids;

    uint32_t Make(uint32_t begin, uint32_t end, uint32_t depth) {
        const uint32_t index = uint32_t(nodes.size());
        nodes.emplace_back();
        Box box, centroidBox;
        for (uint32_t i = begin; i < end; ++i) {
            Grow(box, boxes[ids[i]]);
            Grow(centroidBox, centroids[ids[i]]);
        }
        nodes[index].box = box;
        const uint32_t count = end - begin;
        const uint32_t mid = count <= 1 ? end : Split(begin, end, depth, box, centroidBox);
        if (mid == end) {
            nodes[index].first = begin;
            nodes[index].count = count;
            return index;
        }
        Make(begin, mid, depth + 1);
        const uint32_t second = Make(mid, end, depth + 1);
        nodes[index].first = second;
        return index;
    }

    // Reorders ids[begin, end) into two nonempty halves and returns where the second starts, or
    // returns `end` for a leaf.
    uint32_t Split(uint32_t begin, uint32_t end, uint32_t depth, const Box& box,
                   const Box& centroidBox) {
        const uint32_t count = end - begin;
        const V extent = centroidBox.hi - centroidBox.lo;
        const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0
                         : extent.y >= extent.z                       ? 1
                                                                      : 2;
        if (depth < kSahDepth && extent[axis] > 0.0) {
            int bestAxis = -1, bestBin = 0;
            double bestCost = std::numeric_limits<double>::infinity();
            for (int a = 0; a < 3; ++a) {
                if (!(extent[a] > 0.0)) continue;
                double cost = 0.0;
                const int bin = BestBin(begin, end, a, centroidBox, cost);
                if (cost < bestCost) bestCost = cost, bestAxis = a, bestBin = bin;
            }
            const double leafCost = double(count);
            const double splitCost = 1.0 + bestCost / HalfArea(box);
            if (bestAxis >= 0 && count <= kMaxLeaf && !(splitCost < leafCost)) return end;
            if (bestAxis >= 0 && std::isfinite(splitCost)) {
                const double lo = centroidBox.lo[bestAxis];
                const double scale = kBins / extent[bestAxis];
                const auto it =
                    std::partition(ids.begin() + begin, ids.begin() + end, [&](uint32_t id) {
                        return BinOf(centroids[id][bestAxis], lo, scale) <= bestBin;
                    });
                const uint32_t mid = uint32_t(it - ids.begin());
                if (mid > begin && mid < end) return mid;
            }
        }
        if (count <= kMaxLeaf) return end;
        const uint32_t mid = begin + count / 2;
        std::nth_element(
            ids.begin() + begin, ids.begin() + mid, ids.begin() + end,
            [&](uint32_t a, uint32_t b) { return centroids[a][axis] < centroids[b][axis]; });
        return mid;
    }

    static int BinOf(double c, double lo, double scale) {
        return std::clamp(int((c - lo) * scale), 0, kBins - 1);
    }

    // The bin after which splitting on `axis` costs least, and that cost (areas times counts).
    int BestBin(uint32_t begin, uint32_t end, int axis, const Box& centroidBox, double& cost) {
        std::array<Box, kBins> binBox;
        std::array<uint32_t, kBins> binCount{};
        const double lo = centroidBox.lo[axis];
        const double scale = kBins / (centroidBox.hi[axis] - lo);
        for (uint32_t i = begin; i < end; ++i) {
            const int b = BinOf(centroids[ids[i]][axis], lo, scale);
            Grow(binBox[b], boxes[ids[i]]);
            ++binCount[b];
        }
        std::array<double, kBins> rightCost{};
        Box right;
        uint32_t rightCount = 0;
        for (int b = kBins - 1; b > 0; --b) {
            Grow(right, binBox[b]);
            rightCount += binCount[b];
            rightCost[b] = rightCount ? HalfArea(right) * rightCount : 0.0;
        }
        Box left;
        uint32_t leftCount = 0;
        int best = 0;
        cost = std::numeric_limits<double>::infinity();
        for (int b = 0; b + 1 < kBins; ++b) {
            Grow(left, binBox[b]);
            leftCount += binCount[b];
            if (leftCount == 0 || leftCount == end - begin) continue;
            const double c = HalfArea(left) * leftCount + rightCost[b + 1];
            if (c < cost) cost = c, best = b;
        }
        return best;
    }
};

ReferenceBvh::ReferenceBvh(const scene::Scene& scene, geometry::TriangleTest test)
    : scene_(scene), test_(test) {
    const uint32_t n = scene.PrimitiveCount();
    if (n == 0) return;
    const std::vector<Box> boxes = PaddedPrimitiveBoxes(scene);
    Build build{boxes, std::vector<V>(n), nodes_, ids_};
    for (uint32_t id = 0; id < n; ++id) build.centroids[id] = 0.5 * (boxes[id].lo + boxes[id].hi);
    ids_.resize(n);
    for (uint32_t id = 0; id < n; ++id) ids_[id] = id;
    nodes_.reserve(2 * size_t(n));
    build.Make(0, n, 0);
}

uint32_t ReferenceBvh::LargestLeaf() const {
    uint32_t largest = 0;
    for (const Node& node : nodes_) largest = std::max(largest, node.count);
    return largest;
}

// Visits the leaves whose boxes the ray enters no farther than `bound` (read again after every
// leaf, so a nearer hit prunes the rest), nearer child first. `visit(first, count)` returns
// true to stop.
template <typename T, typename Visit>
void ReferenceBvh::Traverse(const geometry::Ray<T>& ray, const T& bound, Visit&& visit) const {
    if (nodes_.empty()) return;
    const Slabs slabs(ray);
    struct Entry {
        uint32_t node;
        double tNear;
    };
    std::array<Entry, kStackSize> stack;
    int top = 0;
    double tNear = 0.0;
    if (!slabs.Enter(nodes_[0].box, bound, tNear)) return;
    uint32_t node = 0;
    for (;;) {
        const Node& n = nodes_[node];
        if (n.count > 0) {
            if (visit(n.first, n.count)) return;
        } else {
            uint32_t a = node + 1, b = n.first;
            double ta = 0.0, tb = 0.0;
            const bool hitA = slabs.Enter(nodes_[a].box, bound, ta);
            const bool hitB = slabs.Enter(nodes_[b].box, bound, tb);
            if (hitA && hitB) {
                if (tb < ta) std::swap(a, b), std::swap(ta, tb);
                stack[top++] = {b, tb};
                node = a;
                continue;
            }
            if (hitA || hitB) {
                node = hitA ? a : b;
                continue;
            }
        }
        do {
            if (top == 0) return;
            --top;
        } while (stack[top].tNear > bound);
        node = stack[top].node;
    }
}

template <typename T>
geometry::Hit<T> ReferenceBvh::Nearest(const geometry::Ray<T>& ray, uint64_t& tests) const {
    geometry::Hit<T> best;
    best.t = ray.tMax;
    Traverse(ray, best.t, [&](uint32_t first, uint32_t count) {
        for (uint32_t i = first; i < first + count; ++i) {
            geometry::IntersectPrimitive(scene_, ids_[i], ray, best, test_);
        }
        tests += count;
        return false;
    });
    if (!best.Valid()) best.t = std::numeric_limits<T>::infinity();
    return best;
}

template <typename T>
bool ReferenceBvh::Occluded(const geometry::Ray<T>& ray, uint64_t& tests) const {
    bool occluded = false;
    Traverse(ray, ray.tMax, [&](uint32_t first, uint32_t count) {
        for (uint32_t i = first; i < first + count; ++i) {
            ++tests;
            geometry::Hit<T> best;
            best.t = ray.tMax;
            if (geometry::IntersectPrimitive(scene_, ids_[i], ray, best, test_)) {
                occluded = true;
                return true;
            }
        }
        return false;
    });
    return occluded;
}

template geometry::Hit<float> ReferenceBvh::Nearest(const geometry::Ray<float>&, uint64_t&) const;
template geometry::Hit<double> ReferenceBvh::Nearest(const geometry::Ray<double>&, uint64_t&) const;
template bool ReferenceBvh::Occluded(const geometry::Ray<float>&, uint64_t&) const;
template bool ReferenceBvh::Occluded(const geometry::Ray<double>&, uint64_t&) const;

}  // namespace rayclass::render
