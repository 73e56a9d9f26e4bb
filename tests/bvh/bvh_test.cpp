// The SAH builder and the collapse to the kernels' wide tree: every primitive in exactly one leaf,
// every node's box contains its children's boxes and its primitives' boxes, and no walk of the
// wide tree needs more stack than cl/bvh.cl has.
#include "rayclass/bvh/bvh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <random>
#include <string>

#include "rayclass/scene/loader.h"

namespace rayclass::bvh {
namespace {

bool Contains(const Bounds3f& outer, const Bounds3f& b) {
    return outer.lo.x <= b.lo.x && outer.lo.y <= b.lo.y && outer.lo.z <= b.lo.z &&
           outer.hi.x >= b.hi.x && outer.hi.y >= b.hi.y && outer.hi.z >= b.hi.z;
}

// Walks the tree from the root; checks containment and counts each primitive's leaves.
void CheckTree(const Bvh& t, std::span<const Bounds3f> boxes, const BuildParams& params) {
    ASSERT_FALSE(t.nodes.empty());
    std::vector<int> seen(boxes.size(), 0);
    std::vector<uint8_t> visited(t.nodes.size(), 0);
    std::vector<uint32_t> stack{0};
    while (!stack.empty()) {
        const uint32_t i = stack.back();
        stack.pop_back();
        ASSERT_LT(i, t.nodes.size());
        ASSERT_FALSE(visited[i]) << "node " << i << " reached twice";
        visited[i] = 1;
        const BinaryNode& n = t.nodes[i];
        if (n.count > 0) {
            ASSERT_LE(size_t(n.first) + n.count, t.primIndex.size());
            for (uint32_t k = 0; k < n.count; ++k) {
                const uint32_t prim = t.primIndex[n.first + k];
                ASSERT_LT(prim, boxes.size());
                ++seen[prim];
                EXPECT_TRUE(Contains(n.box, boxes[prim])) << "leaf " << i << " prim " << prim;
            }
            continue;
        }
        ASSERT_LT(n.axis, 3u);
        const uint32_t lo = i + 1, hi = n.first;
        ASSERT_GT(hi, lo);
        ASSERT_LT(hi, t.nodes.size());
        EXPECT_TRUE(Contains(n.box, t.nodes[lo].box)) << "node " << i;
        EXPECT_TRUE(Contains(n.box, t.nodes[hi].box)) << "node " << i;
        stack.push_back(lo);
        stack.push_back(hi);
    }
    for (size_t p = 0; p < boxes.size(); ++p) EXPECT_EQ(seen[p], 1) << "primitive " << p;
    for (size_t i = 0; i < visited.size(); ++i) EXPECT_TRUE(visited[i]) << "orphan node " << i;
    EXPECT_LE(t.maxDepth, kMaxDepth);
    (void)params;
}

Bounds3f ChildBox(const RcBvh8Node& n, uint32_t c) {
    Bounds3f b;
    b.lo = {n.loX[c], n.loY[c], n.loZ[c]};
    b.hi = {n.hiX[c], n.hiY[c], n.hiZ[c]};
    return b;
}

// Walks the wide tree as cl/bvh.cl does, pushing every child but one at each node: each primitive
// is in exactly one leaf, inside the boxes of every node above it, each node is reached once, and
// no walk needs more stack entries than the kernels have. Returns the most entries a walk needs.
uint32_t CheckWide(const Bvh& t, std::span<const RcBvh8Node> wide, std::span<const Bounds3f> boxes,
                   uint32_t stackEntries = kStackEntries) {
    EXPECT_FALSE(wide.empty());
    if (wide.empty()) return 0;
    std::vector<int> seen(boxes.size(), 0);
    std::vector<uint8_t> visited(wide.size(), 0);
    uint32_t deepest = 0;
    struct Item {
        uint32_t node, entries;  // entries: pushed by the nodes above
        std::vector<Bounds3f> above;
    };
    std::vector<Item> todo{{0, 0, {}}};
    while (!todo.empty()) {
        const Item item = todo.back();
        todo.pop_back();
        EXPECT_LT(item.node, wide.size());
        if (item.node >= wide.size()) break;
        EXPECT_FALSE(visited[item.node]) << "wide node " << item.node << " reached twice";
        visited[item.node] = 1;
        const RcBvh8Node& n = wide[item.node];
        EXPECT_LE(n.nChildren, 8u);
        EXPECT_TRUE(n.nChildren >= 2 || item.node == 0) << "wide node " << item.node;
        const uint32_t entries = item.entries + (n.nChildren > 0 ? n.nChildren - 1 : 0);
        deepest = std::max(deepest, entries);
        for (uint32_t c = 0; c < n.nChildren; ++c) {
            std::vector<Bounds3f> above = item.above;
            above.push_back(ChildBox(n, c));
            const uint32_t ref = n.child[c];
            if (!(ref & RC_BVH8_LEAF)) {
                EXPECT_GT(ref, item.node);  // depth first
                todo.push_back({ref, entries, std::move(above)});
                continue;
            }
            const uint32_t first = ref & RC_BVH8_FIRST_MASK;
            const uint32_t count = ((ref & ~RC_BVH8_LEAF) >> RC_BVH8_COUNT_SHIFT) + 1;
            EXPECT_LE(size_t(first) + count, t.primIndex.size());
            for (uint32_t k = 0; k < count && first + k < t.primIndex.size(); ++k) {
                const uint32_t prim = t.primIndex[first + k];
                ++seen[prim];
                for (const Bounds3f& b : above) EXPECT_TRUE(Contains(b, boxes[prim])) << prim;
            }
        }
    }
    for (size_t p = 0; p < boxes.size(); ++p) EXPECT_EQ(seen[p], 1) << "primitive " << p;
    for (size_t i = 0; i < visited.size(); ++i) EXPECT_TRUE(visited[i]) << "orphan node " << i;
    EXPECT_LE(deepest, stackEntries);
    return deepest;
}

// n boxes in [-100, 100]^3 with edges up to maxSize (flat: no extent along z, like axis-aligned
// triangles), seeded.
std::vector<Bounds3f> RandomBoxes(uint32_t seed, size_t n, float maxSize, bool flat) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> pos(-100.0f, 100.0f), size(0.0f, maxSize);
    std::vector<Bounds3f> boxes(n);
    for (auto& b : boxes) {
        const glm::vec3 p(pos(rng), pos(rng), pos(rng));
        b.lo = p;
        const float sx = size(rng), sy = size(rng);
        b.hi = p + glm::vec3(sx, sy, flat ? 0.0f : size(rng));
    }
    return boxes;
}

TEST(BvhBuild, RandomBoxes) {
    const std::vector<Bounds3f> boxes = RandomBoxes(7, 5000, 3.0f, /*flat=*/true);
    const BuildParams params;
    const Bvh t = Build(boxes, 1e-4f, params);
    CheckTree(t, boxes, params);
    // SAH splits: far from one leaf per maxLeafSize primitives in a chain.
    EXPECT_LT(t.maxDepth, 40u);
    const std::vector<RcBvh8Node> wide = Collapse(t);
    CheckWide(t, wide, boxes);
    // The stack does not bind on a tree this shallow: a node has eight children unless all of
    // them are leaves.
    for (const RcBvh8Node& n : wide) {
        bool inner = false;
        for (uint32_t c = 0; c < n.nChildren; ++c) inner |= !(n.child[c] & RC_BVH8_LEAF);
        EXPECT_TRUE(n.nChildren == 8 || !inner);
    }
    for (const auto& n : t.nodes) {
        if (n.count > 0) {
            EXPECT_LE(n.count, params.maxLeafSize);
        }
    }
}

TEST(BvhBuild, ThreadsBuildTheSameTreeNodeForNode) {
    // Large enough that subtrees of 32768 primitives or more go to other threads at two levels.
    const std::vector<Bounds3f> boxes = RandomBoxes(11, 200000, 2.0f, /*flat=*/false);
    BuildParams serial;
    serial.threads = 1;
    const Bvh one = Build(boxes, 1e-4f, serial);
    CheckTree(one, boxes, serial);
    for (uint32_t threads : {2u, 4u}) {
        BuildParams params;
        params.threads = threads;
        const Bvh t = Build(boxes, 1e-4f, params);
        ASSERT_EQ(t.nodes.size(), one.nodes.size()) << threads;
        EXPECT_EQ(
            std::memcmp(t.nodes.data(), one.nodes.data(), t.nodes.size() * sizeof(BinaryNode)), 0)
            << threads << " threads";
        EXPECT_EQ(t.primIndex, one.primIndex) << threads;
        EXPECT_EQ(t.maxDepth, one.maxDepth) << threads;
    }
}

// Every node's box is the union of its primitives' boxes, padded as Build documents: the builder
// bounds children while it partitions their parent, and a primitive left out there would leave a
// box too small (or too large) for the kernels.
TEST(BvhBuild, NodeBoxesAreTheirPrimitivesBoxesPadded) {
    const float pad = 1e-4f;
    for (uint32_t seed : {5u, 6u}) {
        const std::vector<Bounds3f> boxes = RandomBoxes(seed, 100000, 1.0f, /*flat=*/seed == 5);
        const Bvh t = Build(boxes, pad);
        CheckTree(t, boxes, {});
        auto outward = [&](float x, float dir) {
            return x + dir * (pad + std::abs(x) * std::ldexp(1.0f, -20));
        };
        // Children come after their parent: bottom up is back to front.
        std::vector<Bounds3f> tight(t.nodes.size());
        for (size_t i = t.nodes.size(); i-- > 0;) {
            const BinaryNode& n = t.nodes[i];
            if (n.count > 0) {
                for (uint32_t k = 0; k < n.count; ++k)
                    tight[i].Grow(boxes[t.primIndex[n.first + k]]);
            } else {
                tight[i].Grow(tight[i + 1]);
                tight[i].Grow(tight[n.first]);
            }
            for (int a = 0; a < 3; ++a) {
                ASSERT_EQ(n.box.lo[a], outward(tight[i].lo[a], -1))
                    << "node " << i << " axis " << a;
                ASSERT_EQ(n.box.hi[a], outward(tight[i].hi[a], 1)) << "node " << i << " axis " << a;
            }
        }
    }
}

TEST(BvhBuild, CoincidentCentroidsAreSplitByCount) {
    std::vector<Bounds3f> boxes(100);
    for (auto& b : boxes) {
        b.lo = glm::vec3(-1.0f);
        b.hi = glm::vec3(1.0f);
    }
    const BuildParams params;
    const Bvh t = Build(boxes, 0.0f, params);
    CheckTree(t, boxes, params);
    for (const auto& n : t.nodes) {
        if (n.count > 0) {
            EXPECT_LE(n.count, params.maxLeafSize);
        }
    }
}

TEST(BvhBuild, SinglePrimitiveIsOneLeaf) {
    std::vector<Bounds3f> boxes(1);
    boxes[0].lo = glm::vec3(0.0f);
    boxes[0].hi = glm::vec3(1.0f);
    const Bvh t = Build(boxes, 0.0f);
    ASSERT_EQ(t.nodes.size(), 1u);
    EXPECT_EQ(t.nodes[0].count, 1u);
    CheckTree(t, boxes, {});
    const std::vector<RcBvh8Node> wide = Collapse(t);
    ASSERT_EQ(wide.size(), 1u);
    EXPECT_EQ(wide[0].nChildren, 1u);
    CheckWide(t, wide, boxes);
}

TEST(BvhCollapse, NoPrimitiveIsARootWithoutChildren) {
    const Bvh t = Build(std::span<const Bounds3f>(), 0.0f);
    const std::vector<RcBvh8Node> wide = Collapse(t);
    ASSERT_EQ(wide.size(), 1u);
    EXPECT_EQ(wide[0].nChildren, 0u);
}

// A binary tree made by hand: a chain of `levels` inner nodes, each with a side subtree of eight
// leaves whose boxes are larger than everything below it on the chain, so that taking the widest
// child first expands the side subtree and pushes seven entries per level of the chain.
// Its side leaves hold kSidePrims primitives each (one box), so that no two fit one leaf of the
// kernels and the optimal collapse keeps them apart too.
constexpr uint32_t kSidePrims = RC_BVH8_MAX_LEAF / 2 + 1;

Bvh SideHeavyChain(uint32_t levels, std::vector<Bounds3f>& boxes) {
    Bvh t;
    std::function<uint32_t(uint32_t, uint32_t)> complete = [&](uint32_t height, uint32_t level) {
        const uint32_t self = uint32_t(t.nodes.size());
        t.nodes.emplace_back();
        if (height == 0) {
            const float s = std::ldexp(1.0f, int(levels - level) + 2);
            const float shift = float(boxes.size() / kSidePrims % 8);
            t.nodes[self].first = uint32_t(t.primIndex.size());
            t.nodes[self].count = kSidePrims;
            for (uint32_t k = 0; k < kSidePrims; ++k) {
                boxes.push_back({glm::vec3(shift), glm::vec3(s + shift)});
                t.primIndex.push_back(uint32_t(boxes.size() - 1));
            }
        } else {
            complete(height - 1, level);
            const uint32_t right = complete(height - 1, level);
            t.nodes[self].first = right;
        }
        return self;
    };
    std::function<uint32_t(uint32_t)> chain = [&](uint32_t level) {
        const uint32_t self = uint32_t(t.nodes.size());
        t.nodes.emplace_back();
        if (level == levels) {
            boxes.push_back({glm::vec3(0.0f), glm::vec3(1.0f)});
            t.nodes[self].first = uint32_t(t.primIndex.size());
            t.nodes[self].count = 1;
            t.primIndex.push_back(uint32_t(boxes.size() - 1));
        } else {
            chain(level + 1);
            t.nodes[self].first = complete(3, level);
        }
        return self;
    };
    chain(0);
    // Boxes bottom up: a node's children come after it.
    for (size_t i = t.nodes.size(); i-- > 0;) {
        BinaryNode& n = t.nodes[i];
        n.box = Bounds3f{};
        if (n.count > 0) {
            n.box = boxes[t.primIndex[n.first]];
        } else {
            n.box.Grow(t.nodes[i + 1].box);
            n.box.Grow(t.nodes[n.first].box);
        }
    }
    return t;
}

TEST(BvhCollapse, SideHeavyChainStaysWithinTheStackItHas) {
    std::vector<Bounds3f> boxes;
    const Bvh t = SideHeavyChain(50, boxes);  // up to 7 entries per level with eight children
    CheckTree(t, boxes, {});
    const uint32_t optimal = CheckWide(t, Collapse(t), boxes);
    const uint32_t height = 53;  // the chain's 50 levels and a side subtree's 3
    ASSERT_GT(optimal, height + 1);
    // Below what the optimal collapse's walks take, the budget binds, is kept and is used: the
    // walks take all but what one more node's children would add.
    for (uint32_t stack = height; stack < optimal; ++stack) {
        SCOPED_TRACE("stack " + std::to_string(stack));
        EXPECT_GT(CheckWide(t, Collapse(t, stack), boxes, stack) + 8, stack);
    }
}

float HalfArea(const Bounds3f& b) {
    const glm::vec3 s = b.hi - b.lo;
    return s.x * s.y + s.y * s.z + s.z * s.x;
}

float LeafSah(float area, uint32_t count) {
    return area * (kLeafCost + kLeafPrimCost * float(count));
}

// The SAH cost of a wide tree: each node's and leaf's cost weighted by its box's area.
float WideSah(std::span<const RcBvh8Node> wide, uint32_t node, float area) {
    const RcBvh8Node& n = wide[node];
    float sum = area * kWideNodeCost;
    for (uint32_t c = 0; c < n.nChildren; ++c) {
        const uint32_t ref = n.child[c];
        const float a = HalfArea(ChildBox(n, c));
        sum += ref & RC_BVH8_LEAF ? LeafSah(a, ((ref & ~RC_BVH8_LEAF) >> RC_BVH8_COUNT_SHIFT) + 1)
                                  : WideSah(wide, ref, a);
    }
    return sum;
}

// The least SAH cost of any wide tree over binary tree t, by enumeration: a node is a leaf of its
// subtree's primitives (at most RC_BVH8_MAX_LEAF) or a wide node whose children are any cut of
// two to eight of its descendants, each again the cheapest of either.
struct BruteCollapse {
    const Bvh& t;
    std::vector<float> best;      // per node, as one root; < 0 until known
    std::vector<uint32_t> prims;  // per node, its subtree's primitives

    explicit BruteCollapse(const Bvh& tree)
        : t(tree), best(tree.nodes.size(), -1.0f), prims(tree.nodes.size(), 0) {
        for (size_t b = t.nodes.size(); b-- > 0;) {
            const BinaryNode& n = t.nodes[b];
            prims[b] = n.count > 0 ? n.count : prims[b + 1] + prims[n.first];
        }
    }

    // The costs of node b's cuts of at most `most` roots, by size.
    std::vector<std::vector<float>> Cuts(uint32_t b, uint32_t most) {
        std::vector<std::vector<float>> cuts(most + 1);
        cuts[1].push_back(Best(b));
        const BinaryNode& n = t.nodes[b];
        if (n.count > 0 || most < 2) return cuts;
        const auto lo = Cuts(b + 1, most - 1), hi = Cuts(n.first, most - 1);
        for (uint32_t i = 1; i < most; ++i)
            for (uint32_t j = 1; i + j <= most; ++j)
                for (float x : lo[i])
                    for (float y : hi[j]) cuts[i + j].push_back(x + y);
        return cuts;
    }

    float Wide(uint32_t b) {
        float cheapest = std::numeric_limits<float>::infinity();
        const BinaryNode& n = t.nodes[b];
        const auto lo = Cuts(b + 1, 7), hi = Cuts(n.first, 7);
        for (uint32_t i = 1; i < 8; ++i)
            for (uint32_t j = 1; i + j <= 8; ++j)
                for (float x : lo[i])
                    for (float y : hi[j]) cheapest = std::min(cheapest, x + y);
        return HalfArea(n.box) * kWideNodeCost + cheapest;
    }

    float Best(uint32_t b) {
        if (best[b] >= 0.0f) return best[b];
        const BinaryNode& n = t.nodes[b];
        const float leaf = prims[b] <= RC_BVH8_MAX_LEAF ? LeafSah(HalfArea(n.box), prims[b])
                                                        : std::numeric_limits<float>::infinity();
        best[b] = n.count > 0 ? leaf : std::min(leaf, Wide(b));
        return best[b];
    }
};

TEST(BvhCollapse, CostsTheLeastSahOfAnyCollapse) {
    // Small random trees of small leaves, so that enumeration stays quick, and of large boxes,
    // so that leaves merge.
    BuildParams params;
    params.maxLeafSize = 2;
    params.traversalCost = 0.5f;
    for (uint32_t seed = 1; seed <= 6; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        const std::vector<Bounds3f> boxes =
            RandomBoxes(seed, 30 + 5 * seed, 200.0f * float(seed), /*flat=*/seed % 2 == 0);
        const Bvh t = Build(boxes, 1e-4f, params);
        const std::vector<RcBvh8Node> wide = Collapse(t);
        CheckWide(t, wide, boxes);
        BruteCollapse brute(t);
        const float least = brute.Wide(0);
        EXPECT_NEAR(WideSah(wide, 0, HalfArea(t.nodes[0].box)), least, 1e-5f * least);
    }
}

TEST(BvhCollapse, WalksStayWithinAnyStackAsHighAsTheTree) {
    // Seeded random trees, each collapsed for stacks from its own height up: the budget binds
    // at the small ones and every walk must still fit.
    for (uint32_t seed = 1; seed <= 12; ++seed) {
        const std::vector<Bounds3f> boxes =
            RandomBoxes(seed, 500 + 300 * seed, 0.5f + float(seed), /*flat=*/seed % 2 == 0);
        const Bvh t = Build(boxes, 1e-4f);
        for (uint32_t extra : {0u, 1u, 3u, 7u, 15u, 200u}) {
            const uint32_t stack = t.maxDepth + extra;
            const std::vector<RcBvh8Node> wide = Collapse(t, stack);
            SCOPED_TRACE("seed " + std::to_string(seed) + ", stack " + std::to_string(stack));
            CheckWide(t, wide, boxes, stack);
        }
    }
    std::vector<Bounds3f> boxes;
    const Bvh chain = SideHeavyChain(50, boxes);
    for (uint32_t stack : {53u, 54u, 60u, 100u}) {
        SCOPED_TRACE("chain, stack " + std::to_string(stack));
        CheckWide(chain, Collapse(chain, stack), boxes, stack);
    }
    try {
        Collapse(chain, 20);
        FAIL() << "no error";
    } catch (const std::runtime_error& e) {
        EXPECT_STREQ(e.what(), "bvh: the tree needs a stack of 53 entries, more than 20");
    }
}

TEST(BvhCollapse, LeavesTooLongForTheKernelsFail) {
    const std::vector<Bounds3f> boxes = RandomBoxes(3, 60, 3.0f, /*flat=*/false);
    BuildParams params;
    params.maxLeafSize = 64;
    params.traversalCost = 1e6f;  // splitting never pays
    const Bvh t = Build(boxes, 0.0f, params);
    ASSERT_GT(t.nodes[0].count, RC_BVH8_MAX_LEAF);
    try {
        Collapse(t);
        FAIL() << "no error";
    } catch (const std::runtime_error& e) {
        EXPECT_STREQ(e.what(), "bvh: a leaf of 60 primitives, more than the kernels take (16)");
    }
}

TEST(BvhBuild, SceneWithAllPrimitiveKinds) {
    const char* source = std::getenv("RAYCLASS_SOURCE_DIR");
    const auto dir = std::filesystem::path(source ? source : ".") / "scenes";
    for (const char* file : {"cornell.json", "tests/quadrics.json", "tests/spheres.json"}) {
        const scene::Scene scene = scene::LoadScene(dir / file);
        std::vector<Bounds3f> boxes(scene.PrimitiveCount());
        for (uint32_t id = 0; id < boxes.size(); ++id) boxes[id] = scene.PrimitiveBounds(id);
        const Bvh t = Build(scene);
        CheckTree(t, boxes, {});
        CheckWide(t, Collapse(t), boxes);
    }
}

}  // namespace
}  // namespace rayclass::bvh
