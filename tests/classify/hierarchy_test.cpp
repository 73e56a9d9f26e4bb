#include "rayclass/classify/hierarchy.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <iterator>
#include <limits>
#include <memory>
#include <numeric>
#include <random>
#include <set>
#include <string>

#include "classify_support.h"
#include "rayclass/classify/query.h"
#include "rayclass/geometry/offset.h"

namespace rayclass::classify {
namespace {

// Eye rays from one point, random rays from inside and outside the box, and some that miss.
std::vector<Ray> RandomRays(uint32_t seed, int n) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> pos(-1.2f, 1.2f), far(-4.0f, 4.0f), cone(-0.4f, 0.4f);
    std::vector<Ray> rays;
    const glm::vec3 eye(-1.5f, 0.1f, 0.2f);
    for (int i = 0; i < n; ++i) {
        Ray r;
        switch (i % 3) {
            case 0:
                r.origin = eye;
                r.direction = glm::normalize(glm::vec3(1.0f, cone(rng), cone(rng)));
                break;
            case 1:
                r.origin = glm::vec3(pos(rng), pos(rng), pos(rng));
                r.direction = RandomDirection(rng);
                break;
            default:
                r.origin = glm::vec3(far(rng), far(rng), far(rng));
                r.direction = RandomDirection(rng);
                break;
        }
        rays.push_back(r);
    }
    return rays;
}

TEST(Hierarchy, EveryRayLandsInExactlyOneLeaf) {
    for (uint32_t seed = 1; seed <= 3; ++seed) {
        const scene::Scene s = RandomScene(seed, 300, 10, 5);
        const auto rays = RandomRays(seed + 100, 3000);
        Hierarchy h(s, DeepParams(s));
        const LeafBatch batch = h.Classify(rays);
        ExpectEveryRayOnce(batch, uint32_t(rays.size()));
        EXPECT_GT(batch.leaves.size(), 50u);
    }
}

TEST(Hierarchy, LeafListHoldsTheBruteForceHit) {
    const scene::Scene s = RandomScene(7, 400, 10, 5);
    const auto rays = RandomRays(8, 3000);
    Hierarchy h(s, DeepParams(s));
    const LeafBatch batch = h.Classify(rays);
    const auto truth = BruteForce(s, rays);
    int nHits = 0;
    for (const RcLeaf& leaf : batch.leaves) {
        std::set<uint32_t> list;
        for (uint32_t c = 0; c < leaf.candCount; ++c) {
            list.insert(batch.candidates[leaf.candBegin + c].prim);
        }
        for (uint32_t j = 0; j < leaf.rayCount; ++j) {
            const uint32_t id = batch.rayIndex[leaf.rayBegin + j];
            if (!truth[id].Valid()) continue;
            ++nHits;
            EXPECT_TRUE(list.count(truth[id].prim)) << "ray " << id << " prim " << truth[id].prim;
        }
    }
    for (uint32_t id : batch.missed) EXPECT_FALSE(truth[id].Valid()) << "missed ray " << id;
    EXPECT_GT(nHits, 1000);
}

TEST(Hierarchy, ListsAreSortedByNearDistance) {
    const scene::Scene s = RandomScene(9, 300, 0, 0);
    const auto rays = RandomRays(10, 2000);
    Hierarchy h(s, DeepParams(s));
    const LeafBatch batch = h.Classify(rays);
    for (const RcLeaf& leaf : batch.leaves) {
        const RcCandidate* c = batch.candidates.data() + leaf.candBegin;
        for (uint32_t i = 1; i < leaf.candCount; ++i) ASSERT_LE(c[i - 1].nearX, c[i].nearX);
    }
}

TEST(Hierarchy, DistanceOptimisedQueryEqualsBruteForce) {
    for (uint32_t seed = 11; seed <= 13; ++seed) {
        const scene::Scene s = RandomScene(seed, 400, 15, 5);
        const auto rays = RandomRays(seed + 100, 3000);
        Hierarchy h(s, DeepParams(s));
        const LeafBatch batch = h.Classify(rays);
        ExpectSameHits(Query(s, batch, rays), BruteForce(s, rays));
    }
}

TEST(Hierarchy, QueryEqualsBruteForceForEverySplitVariant) {
    const scene::Scene s = RandomScene(21, 300, 10, 5);
    const auto rays = RandomRays(22, 2000);
    const auto truth = BruteForce(s, rays);
    for (SplitRule rule : {SplitRule::kMidpoint, SplitRule::kMedian}) {
        for (int splitsPerList : {1, 3}) {
            Params p = DeepParams(s);
            p.splitRule = rule;
            p.splitsPerList = splitsPerList;
            p.dirWeight = 0.5f;
            Hierarchy h(s, p);
            ExpectSameHits(Query(s, h.Classify(rays), rays), truth);
        }
    }
    // Default parameters: few splits at this ray count, still exact.
    Hierarchy h(s, Params::ForScene(s));
    ExpectSameHits(Query(s, h.Classify(rays), rays), truth);
}

TEST(Hierarchy, ShrunkIntervalsContainTheirRays) {
    const scene::Scene s = RandomScene(31, 300, 5, 2);
    const auto rays = RandomRays(32, 3000);
    Hierarchy h(s, DeepParams(s));
    const LeafBatch batch = h.Classify(rays);
    const auto& nodes = h.Nodes();
    for (const RcLeaf& leaf : batch.leaves) {
        for (uint32_t j = 0; j < leaf.rayCount; ++j) {
            const uint32_t id = batch.rayIndex[leaf.rayBegin + j];
            Ray5 r;
            ASSERT_TRUE(ToRay5(rays[id], h.SceneBox(), r));
            EXPECT_EQ(uint32_t(r.face), leaf.face);
            EXPECT_TRUE(nodes[leaf.node].box.Contains(r.p)) << "ray " << id;
        }
    }
    // Children shrink inside their parent and are disjoint in the split.
    int nSplit = 0;
    for (const Node& n : nodes) {
        if (n.IsLeaf()) continue;
        ++nSplit;
        for (uint32_t c : n.child) EXPECT_TRUE(n.box.Contains(nodes[c].box));
    }
    EXPECT_GT(nSplit, 20);
}

TEST(Hierarchy, RemainderReceivesExactlyTheRaysOutsideTheChildren) {
    const scene::Scene s = RandomScene(41, 300, 5, 2);
    const auto first = RandomRays(42, 3000);
    const auto second = RandomRays(43, 3000);
    Hierarchy h(s, DeepParams(s));
    h.Classify(first);
    const LeafBatch batch = h.Classify(second);
    ExpectEveryRayOnce(batch, uint32_t(second.size()));
    const auto& nodes = h.Nodes();
    int nInRemainder = 0;
    for (const RcLeaf& leaf : batch.leaves) {
        for (uint32_t j = 0; j < leaf.rayCount; ++j) {
            const uint32_t id = batch.rayIndex[leaf.rayBegin + j];
            Ray5 r;
            ASSERT_TRUE(ToRay5(second[id], h.SceneBox(), r));
            // Walk the path by hand: a ray enters the remainder iff no child contains it.
            uint32_t node = h.FaceRoot(r.face);
            bool viaRemainder = false;
            while (node != leaf.node) {
                const Node& n = nodes[node];
                ASSERT_FALSE(n.IsLeaf()) << "ray " << id << " left the path";
                const bool in0 = nodes[n.child[0]].box.Contains(r.p);
                const bool in1 = nodes[n.child[1]].box.Contains(r.p);
                ASSERT_FALSE(in0 && in1);
                if (in0 || in1) {
                    node = n.child[in0 ? 0 : 1];
                } else {
                    ASSERT_NE(n.remainder, kNoNode);
                    node = n.remainder;
                    viaRemainder = true;
                }
            }
            EXPECT_EQ(h.Route(r), leaf.node);
            nInRemainder += viaRemainder ? 1 : 0;
        }
    }
    EXPECT_GT(nInRemainder, 300);
}

TEST(Hierarchy, SecondGenerationMatchesAFreshHierarchy) {
    const scene::Scene s = RandomScene(51, 400, 10, 5);
    const auto first = RandomRays(52, 3000);
    // Second generation: mirror rays off the first generation's hits.
    std::vector<Ray> second;
    for (const Ray& r : first) {
        const Hit<float> hit = geometry::IntersectBruteForce(s, ToGeometryRay(r));
        if (!hit.Valid() || hit.prim >= s.SphereBase()) continue;
        const auto& p = s.triangles[hit.prim].p;
        glm::vec3 n = glm::normalize(glm::cross(p[1] - p[0], p[2] - p[0]));
        if (glm::dot(n, r.direction) > 0.0f) n = -n;
        Ray m;
        m.origin = geometry::OffsetRayOrigin(r.origin + hit.t * r.direction, n);
        m.direction = glm::reflect(r.direction, n);
        second.push_back(m);
    }
    ASSERT_GT(second.size(), 500u);
    Hierarchy shared(s, DeepParams(s));
    shared.Classify(first);
    const auto sharedHits = Query(s, shared.Classify(second), second);
    Hierarchy fresh(s, DeepParams(s));
    ExpectSameHits(sharedHits, Query(s, fresh.Classify(second), second));
    ExpectSameHits(sharedHits, BruteForce(s, second));
    // A third generation (the first again) through both remainders and old leaves.
    ExpectSameHits(Query(s, shared.Classify(first), first), BruteForce(s, first));
}

void ExpectSameLeaves(const LeafBatch& a, const LeafBatch& b, bool sameNodeIds);

TEST(Hierarchy, InsertAppendsRaysOfOneGeneration) {
    const scene::Scene s = RandomScene(61, 200, 0, 0);
    const auto a = RandomRays(62, 1000);
    const auto b = RandomRays(63, 1000);
    std::vector<Ray> both = a;
    both.insert(both.end(), b.begin(), b.end());
    // On several threads each array is cut into pieces, whose runs in each face's slab are
    // then moved together: the same leaves as on one thread.
    std::vector<LeafBatch> got;
    for (const uint32_t threads : {1u, 2u, 3u}) {
        Params p = DeepParams(s);
        p.threads = threads;
        Hierarchy h(s, p);
        h.Insert(a);
        h.Insert(b);
        got.push_back(h.Subdivide());
        ExpectEveryRayOnce(got.back(), uint32_t(both.size()));
        ExpectSameHits(Query(s, got.back(), both), BruteForce(s, both));
        ExpectSameLeaves(got.back(), got[0], false);
    }
}

// The renderer classifies rays in place inside RcRay records (8 floats); other records that begin
// with a ray (here 12 floats) are read through the generic strided path: a strided view must give
// exactly the leaves of the packed rays (the vector path and the scalar tail alike).
TEST(Hierarchy, StridedViewsClassifyLikePackedRays) {
    const scene::Scene s = RandomScene(65, 200, 4, 2);
    auto rays = RandomRays(66, 1003);
    rays[5].direction = glm::vec3(0.0f);  // an empty shadow slot: no direction
    Hierarchy packed(s, DeepParams(s));
    const LeafBatch expected = packed.Classify(rays);
    for (const size_t floats : {8u, 12u}) {
        std::vector<float> records(rays.size() * floats, -7.0f);
        for (size_t i = 0; i < rays.size(); ++i) {
            std::memcpy(&records[i * floats], &rays[i], sizeof(Ray));
        }
        Hierarchy strided(s, DeepParams(s));
        const LeafBatch got =
            strided.Classify(RayView(records.data(), rays.size(), floats * sizeof(float)));
        EXPECT_EQ(got.rayIndex, expected.rayIndex) << floats;
        EXPECT_EQ(got.missed, expected.missed) << floats;
        ASSERT_EQ(got.leaves.size(), expected.leaves.size()) << floats;
        for (size_t l = 0; l < got.leaves.size(); ++l) {
            EXPECT_EQ(got.leaves[l].rayBegin, expected.leaves[l].rayBegin);
            EXPECT_EQ(got.leaves[l].candCount, expected.leaves[l].candCount);
        }
    }
}

// Every leaf's list lies inside the batch's candidates, and no two overlap.
void ExpectListsApart(const LeafBatch& b) {
    std::vector<std::pair<size_t, size_t>> ranges;
    for (const RcLeaf& leaf : b.leaves) {
        ASSERT_LE(size_t(leaf.candBegin) + leaf.candCount, b.candidates.size());
        if (leaf.candCount > 0)
            ranges.emplace_back(leaf.candBegin, leaf.candBegin + leaf.candCount);
    }
    std::sort(ranges.begin(), ranges.end());
    for (size_t i = 1; i < ranges.size(); ++i) {
        ASSERT_LE(ranges[i - 1].second, ranges[i].first) << "lists overlap";
    }
}

// The same leaves with the same lists; where the lists lie depends on which thread wrote them.
void ExpectSameLeaves(const LeafBatch& a, const LeafBatch& b, bool sameNodeIds) {
    EXPECT_EQ(a.rayIndex, b.rayIndex);
    EXPECT_EQ(a.missed, b.missed);
    EXPECT_EQ(a.nRays, b.nRays);
    ExpectListsApart(a);
    ExpectListsApart(b);
    ASSERT_EQ(a.leaves.size(), b.leaves.size());
    for (size_t l = 0; l < a.leaves.size(); ++l) {
        const RcLeaf &x = a.leaves[l], &y = b.leaves[l];
        ASSERT_TRUE(x.rayBegin == y.rayBegin && x.rayCount == y.rayCount &&
                    x.candCount == y.candCount && x.face == y.face &&
                    (!sameNodeIds || x.node == y.node))
            << "leaf " << l;
        for (uint32_t c = 0; c < x.candCount; ++c) {
            const RcCandidate &p = a.candidates[x.candBegin + c],
                              &q = b.candidates[y.candBegin + c];
            ASSERT_TRUE(p.prim == q.prim && p.nearX == q.nearX) << "leaf " << l << " entry " << c;
        }
    }
}

void ExpectSameNodes(const Hierarchy& a, const Hierarchy& b) {
    ASSERT_EQ(a.Nodes().size(), b.Nodes().size());
    for (size_t i = 0; i < a.Nodes().size(); ++i) {
        const Node &x = a.Nodes()[i], &y = b.Nodes()[i];
        ASSERT_TRUE(x.box.lo == y.box.lo && x.box.hi == y.box.hi && x.child[0] == y.child[0] &&
                    x.child[1] == y.child[1] && x.remainder == y.remainder && x.face == y.face &&
                    x.depth == y.depth && x.isRemainder == y.isRemainder)
            << "node " << i;
    }
}

// The hierarchy's shape without its ids: nodes in depth-first order from the face roots (first
// child, second child, remainder). Fails when a node is reached twice or not at all.
std::vector<std::string> Shape(const Hierarchy& h) {
    std::vector<std::string> out;
    std::vector<int> seen(h.Nodes().size(), 0);
    std::vector<uint32_t> stack;
    for (int f = kFaceCount - 1; f >= 0; --f) stack.push_back(h.FaceRoot(f));
    while (!stack.empty()) {
        const uint32_t id = stack.back();
        stack.pop_back();
        EXPECT_LT(id, h.Nodes().size());
        if (id >= h.Nodes().size() || seen[id]++) {
            ADD_FAILURE() << "node " << id << " reached twice or out of range";
            return out;
        }
        const Node& n = h.Nodes()[id];
        std::string line;
        for (int k = 0; k < kDims; ++k) {
            line += std::to_string(n.box.lo[k]) + " " + std::to_string(n.box.hi[k]) + " ";
        }
        line += std::to_string(n.face) + " " + std::to_string(n.depth) + " " +
                std::to_string(n.isRemainder) + (n.IsLeaf() ? " leaf" : " split") +
                (n.remainder == kNoNode ? "" : " +remainder");
        out.push_back(line);
        if (n.remainder != kNoNode) stack.push_back(n.remainder);
        if (!n.IsLeaf()) {
            stack.push_back(n.child[1]);
            stack.push_back(n.child[0]);
        }
    }
    EXPECT_EQ(out.size(), h.Nodes().size()) << "nodes not reachable from the face roots";
    return out;
}

// Subdivide's tasks depend on the rays alone: every thread count gives the same leaves, lists and
// nodes, over generations that route through earlier splits and spawn remainders. Small task
// sizes make many tasks (new roots linked across parts, remainders made in a task's part).
TEST(Hierarchy, ThreadCountDoesNotChangeTheResult) {
    const scene::Scene s = RandomScene(71, 500, 10, 4);
    const auto first = RandomRays(72, 12000);
    const auto second = RandomRays(73, 9000);
    Params serial = DeepParams(s);
    serial.threads = 1;
    serial.taskRays = 1u << 30;  // one task per face: the plain recursion
    Hierarchy reference(s, serial);
    const LeafBatch ref[4] = {reference.Classify(first), reference.Classify(second),
                              reference.Classify(first), reference.Classify(second)};
    ExpectSameHits(Query(s, ref[1], second), BruteForce(s, second));
    std::unique_ptr<Hierarchy> oneThread;
    for (const uint32_t threads : {1u, 2u, 3u}) {
        SCOPED_TRACE(threads);
        Params p = DeepParams(s);
        p.threads = threads;
        p.taskRays = 64;
        auto h = std::make_unique<Hierarchy>(s, p);
        const LeafBatch got[4] = {h->Classify(first), h->Classify(second), h->Classify(first),
                                  h->Classify(second)};
        for (int g = 0; g < 4; ++g) ExpectSameLeaves(got[g], ref[g], false);
        ExpectSameHits(Query(s, got[2], first), BruteForce(s, first));
        EXPECT_EQ(Shape(*h), Shape(reference));
        if (!oneThread) {
            oneThread = std::move(h);
            continue;
        }
        ExpectSameNodes(*h, *oneThread);
        Hierarchy again(s, p);
        for (const auto* rays : {&first, &second, &first, &second}) again.Classify(*rays);
        ExpectSameNodes(again, *oneThread);
    }
}

// A split whose rays already lie on their sides in order (eye rays in pixel order: a row of
// pixels is an interval of one slope) moves no ray, and gives the same tree, the same lists and
// the same rays per leaf as the same rays shuffled, which every split moves.
TEST(Hierarchy, RaysAlreadyInSplitOrderAreNotMoved) {
    const scene::Scene s = RandomScene(81, 400, 6, 2);
    std::vector<Ray> rows;
    const int width = 96, height = 64;
    for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) {
            Ray r;
            r.origin = glm::vec3(-1.5f, 0.1f, 0.2f);
            r.direction = glm::normalize(glm::vec3(1.0f, 0.6f * (1.0f - 2.0f * (y + 0.5f) / height),
                                                   0.8f * (2.0f * (x + 0.5f) / width - 1.0f)));
            rows.push_back(r);
        }
    }
    std::vector<uint32_t> order(rows.size());
    std::iota(order.begin(), order.end(), 0u);
    std::shuffle(order.begin(), order.end(), std::mt19937(82));
    std::vector<Ray> shuffled;
    for (uint32_t i : order) shuffled.push_back(rows[i]);

    Params p = DeepParams(s);
    p.planRays = 0;  // a plan's bucketing moves every ray, in order or not
    Hierarchy inOrder(s, p), mixed(s, p);
    const LeafBatch a = inOrder.Classify(rows), b = mixed.Classify(shuffled);
    EXPECT_EQ(Shape(inOrder), Shape(mixed));
    // Per leaf: its node's box, its list and its rays (as indices into `rows`).
    auto leaves = [](const Hierarchy& h, const LeafBatch& batch, const std::vector<uint32_t>* map) {
        std::multiset<std::string> out;
        for (const RcLeaf& leaf : batch.leaves) {
            std::set<uint32_t> rays;
            for (uint32_t j = 0; j < leaf.rayCount; ++j) {
                const uint32_t id = batch.rayIndex[leaf.rayBegin + j];
                rays.insert(map ? (*map)[id] : id);
            }
            std::string key;
            for (int k = 0; k < kDims; ++k) {
                key += std::to_string(h.Nodes()[leaf.node].box.lo[k]) + " " +
                       std::to_string(h.Nodes()[leaf.node].box.hi[k]) + " ";
            }
            for (uint32_t c = 0; c < leaf.candCount; ++c) {
                key += std::to_string(batch.candidates[leaf.candBegin + c].prim) + ",";
            }
            key += "|";
            for (uint32_t r : rays) key += std::to_string(r) + ",";
            out.insert(key);
        }
        return out;
    };
    EXPECT_EQ(leaves(inOrder, a, nullptr), leaves(mixed, b, &order));
    EXPECT_GT(a.leaves.size(), 20u);
    // Only the splits across the pixel rows' order move rays: far fewer moves.
    EXPECT_LT(inOrder.Counters().rayMoves, mixed.Counters().rayMoves * 3 / 4);
    ExpectSameHits(Query(s, a, rows), BruteForce(s, rows));
}

// The 5D conversion splits a generation into one piece per thread. Rays its slow path maps (a
// start outside the box: clipped, or missing it) follow the other rays of their run of 16, so
// pieces must start at the same runs for every thread count: the leaves must not depend on it
// (they did, for piece sizes not a multiple of 16), and the queries must equal brute force.
TEST(Hierarchy, ConversionDoesNotDependOnTheThreadCount) {
    const scene::Scene s = RandomScene(101, 400, 6, 2);
    std::mt19937 rng(102);
    std::uniform_real_distribution<float> cone(-0.5f, 0.5f), start(0.0f, 6.0f);
    std::vector<Ray> oneFace;
    for (int i = 0; i < 20000; ++i) {
        Ray r;
        r.origin = glm::vec3(-1.5f, 0.1f, 0.2f);
        r.direction = glm::normalize(glm::vec3(1.0f, cone(rng), cone(rng)));
        // Some along +y, and after the first 9,000 every seventh starts past the box.
        if (i % 312 == 150) r.direction = glm::normalize(glm::vec3(cone(rng), 1.0f, cone(rng)));
        if (i > 9000 && i % 7 == 0) r.tMin = 4.0f + start(rng);
        oneFace.push_back(r);
    }
    std::vector<Ray> mixed = oneFace;
    const auto random = RandomRays(103, 7000);
    mixed.insert(mixed.end(), random.begin(), random.end());
    for (const auto* rays : {&oneFace, &mixed}) {
        std::vector<LeafBatch> got;
        for (const uint32_t threads : {1u, 2u, 3u}) {
            Params p = DeepParams(s);
            p.threads = threads;
            p.taskRays = 512;
            Hierarchy h(s, p);
            got.push_back(h.Classify(*rays));
            ExpectSameHits(Query(s, got.back(), *rays), BruteForce(s, *rays));
        }
        EXPECT_GT(got[0].missed.size(), 1000u);
        for (size_t t = 1; t < got.size(); ++t) ExpectSameLeaves(got[t], got[0], false);
    }
}

// Convert stores a face's coordinate only once its rays differ there (eye rays' origins and the
// ends of unbounded rays are never stored). Where they differ late, within an array or only
// between arrays, the rays before get the held value; where they never differ, the held value
// is the node boxes' constant. An eye's array alone, and two arrays from two eyes inserted apart
// or as one: the leaves contain their rays and are the same on every thread count.
TEST(Hierarchy, HeldCoordinatesAreStoredOnceTheyVary) {
    const scene::Scene s = RandomScene(111, 400, 6, 2);
    std::mt19937 rng(112);
    std::uniform_real_distribution<float> cone(-0.5f, 0.5f);
    auto eyeRays = [&](glm::vec3 eye, int n, int boundedFrom, bool someOutside) {
        std::vector<Ray> rays;
        for (int i = 0; i < n; ++i) {
            Ray r;
            r.origin = eye;
            r.direction = glm::normalize(glm::vec3(1.0f, cone(rng), cone(rng)));
            if (i >= boundedFrom) r.tMax = 1.7f;
            // These start outside the box: the slow path maps them, clipped.
            if (someOutside && i % 97 == 40) r.origin = eye - 3.0f * r.direction;
            rays.push_back(r);
        }
        return rays;
    };
    // Multiples of 16 rays, so that both ways of inserting cut the same runs of 16.
    const auto a = eyeRays({-0.9f, 0.1f, 0.2f}, 2000, 2000, false);
    const auto b = eyeRays({-0.8f, -0.2f, 0.1f}, 2400, 1001, true);
    std::vector<Ray> both = a;
    both.insert(both.end(), b.begin(), b.end());
    enum Mode { kAlone, kApart, kAsOne };
    std::vector<LeafBatch> got[2];  // a alone; a and b
    for (const Mode mode : {kAlone, kApart, kAsOne}) {
        const std::vector<Ray>& all = mode == kAlone ? a : both;
        const auto brute = BruteForce(s, all);
        std::vector<LeafBatch>& same = got[mode == kAlone ? 0 : 1];
        for (const uint32_t threads : {1u, 2u, 3u}) {
            SCOPED_TRACE("mode " + std::to_string(int(mode)) + ", " + std::to_string(threads) +
                         " threads");
            Params p = DeepParams(s);
            p.threads = threads;
            Hierarchy h(s, p);
            if (mode == kApart) {
                h.Insert(a);
                h.Insert(b);
            } else {
                h.Insert(all);
            }
            same.push_back(h.Subdivide());
            const LeafBatch& batch = same.back();
            ExpectEveryRayOnce(batch, uint32_t(all.size()));
            ExpectSameHits(Query(s, batch, all), brute);
            for (const RcLeaf& leaf : batch.leaves) {
                for (uint32_t j = 0; j < leaf.rayCount; ++j) {
                    const uint32_t id = batch.rayIndex[leaf.rayBegin + j];
                    Ray5 r;
                    ASSERT_TRUE(ToRay5(all[id], h.SceneBox(), r));
                    ASSERT_TRUE(h.Nodes()[leaf.node].box.Contains(r.p)) << "ray " << id;
                }
            }
            EXPECT_GT(batch.leaves.size(), 20u);
            ExpectSameLeaves(batch, same[0], false);
        }
    }
}

// Rays that start outside the scene box are clipped to it on the way into 5D. Every leaf below a
// face root has its rays' tight bounds as its box, so comparing those boxes with the bounds of
// ToRay5's points checks the conversion bit for bit: eyes outside the box on every side, starts
// moved by tMin, ends before and inside the box, axis-parallel rays inside and outside a slab,
// rays along a face plane, rays that touch an edge at one point, rays that point away, and far
// random rays.
TEST(Hierarchy, ClippedRaysMapExactlyAsToRay5) {
    const scene::Scene s = RandomScene(121, 300, 5, 2);
    std::mt19937 rng(122);
    std::uniform_real_distribution<float> in(-1.0f, 1.0f), far(-5.0f, 5.0f), unit(0.0f, 1.0f);
    Hierarchy probe(s, DeepParams(s));
    const Bounds3f box = probe.SceneBox();
    std::vector<Ray> rays;
    const glm::vec3 eyes[] = {{-3.0f, 0.1f, 0.2f},  {3.2f, -0.3f, 0.1f}, {0.2f, 3.5f, -0.1f},
                              {-0.1f, -3.1f, 0.3f}, {0.1f, -0.2f, 4.0f}, {0.3f, 0.2f, -3.3f},
                              {2.5f, 2.5f, 2.5f}};
    for (int i = 0; i < 3000; ++i) {
        Ray r;
        const glm::vec3 eye = eyes[size_t(i) % std::size(eyes)];
        r.origin = eye;
        r.direction = glm::normalize(glm::vec3(in(rng), in(rng), in(rng)) - eye);
        switch (i % 11) {
            case 1:
                r.tMin = 0.5f * unit(rng);
                break;  // still outside
            case 2:
                r.tMax = 0.5f + 4.0f * unit(rng);
                break;  // may end before
            case 3:
                r.direction = -r.direction;
                break;  // points away
            case 4:
                r.origin = glm::vec3(far(rng), far(rng), far(rng));  // anywhere
                r.direction = RandomDirection(rng);
                break;
            case 5: {  // axis-parallel, inside or outside the other two slabs, just outside
                const int a = i % 3;
                r.origin = glm::vec3(in(rng), in(rng), in(rng)) * 1.5f;
                r.origin[a] = box.lo[a] - 0.05f - 0.3f * unit(rng);
                r.direction = glm::vec3(0.0f);
                r.direction[a] = 1.0f;
                break;
            }
            case 6: {  // along the box's lower y plane, from outside in x
                r.origin = glm::vec3(-4.0f, box.lo.y, in(rng));
                r.direction = glm::normalize(glm::vec3(1.0f, 0.0f, 0.3f * in(rng)));
                break;
            }
            case 7: {  // touches the box's edge x = lo.x, y = hi.y: enters x as it leaves y
                const float delta = 0.0625f;  // exact steps from the box's faces
                r.origin = glm::vec3(box.lo.x - delta, box.hi.y - delta, 0.9f * in(rng));
                r.direction = glm::vec3(1.0f, 1.0f, 0.0f);
                break;
            }
            default:
                break;
        }
        rays.push_back(r);
    }
    const auto brute = BruteForce(s, rays);
    for (const uint32_t threads : {1u, 2u}) {
        SCOPED_TRACE(std::to_string(threads) + " threads");
        Params p = DeepParams(s);
        p.threads = threads;
        Hierarchy h(s, p);
        const LeafBatch batch = h.Classify(rays);
        ExpectEveryRayOnce(batch, uint32_t(rays.size()));
        ExpectSameHits(Query(s, batch, rays), brute);
        std::vector<bool> missed(rays.size(), false);
        for (const uint32_t id : batch.missed) missed[id] = true;
        int clipped = 0, compared = 0;
        for (uint32_t i = 0; i < rays.size(); ++i) {
            Ray5 r;
            const bool mapped = ToRay5(rays[i], box, r);
            ASSERT_EQ(mapped, !missed[i]) << "ray " << i;
            const glm::vec3 start = rays[i].origin + rays[i].tMin * rays[i].direction;
            clipped +=
                mapped && glm::any(glm::lessThan(start, box.lo) || glm::greaterThan(start, box.hi));
        }
        EXPECT_GT(clipped, 1500);
        for (const RcLeaf& leaf : batch.leaves) {
            const Node& node = h.Nodes()[leaf.node];
            if (node.depth == 0 || node.isRemainder) continue;
            Box5 tight;
            tight.lo.fill(std::numeric_limits<float>::infinity());
            tight.hi.fill(-std::numeric_limits<float>::infinity());
            float endHi = -std::numeric_limits<float>::infinity();
            for (uint32_t j = 0; j < leaf.rayCount; ++j) {
                Ray5 r;
                ASSERT_TRUE(ToRay5(rays[batch.rayIndex[leaf.rayBegin + j]], box, r));
                for (int k = 0; k < kDims; ++k) {
                    tight.lo[k] = std::min(tight.lo[k], r.p[k]);
                    tight.hi[k] = std::max(tight.hi[k], r.p[k]);
                }
                endHi = std::max(endHi, std::min(r.p[0] + r.reach, BoxInFace(r.face, box).hi[0]));
            }
            // The clipped reach ends the lists: no entry starts beyond the leaf's last end (but
            // for the lists' 16-bit rounding).
            for (uint32_t c = 0; c < leaf.candCount; ++c) {
                ASSERT_LE(batch.candidates[leaf.candBegin + c].nearX, endHi + 1e-3f)
                    << "leaf node " << leaf.node << " entry " << c;
            }
            for (int k = 0; k < kDims; ++k) {
                ASSERT_EQ(std::bit_cast<uint32_t>(node.box.lo[k]),
                          std::bit_cast<uint32_t>(tight.lo[k]))
                    << "leaf node " << leaf.node << " coordinate " << k;
                ASSERT_EQ(std::bit_cast<uint32_t>(node.box.hi[k]),
                          std::bit_cast<uint32_t>(tight.hi[k]))
                    << "leaf node " << leaf.node << " coordinate " << k;
            }
            ++compared;
        }
        EXPECT_GT(compared, 50);
    }
}

// Reset forgets every split (a new frame, as raybench --warm uses it): the next generation
// classifies exactly as in a fresh hierarchy, node ids included.
TEST(Hierarchy, ResetClassifiesLikeAFreshHierarchy) {
    const scene::Scene s = RandomScene(91, 300, 6, 2);
    const auto first = RandomRays(92, 6000), second = RandomRays(93, 5000);
    Hierarchy used(s, DeepParams(s)), fresh(s, DeepParams(s));
    used.Classify(first);
    used.Classify(second);
    ASSERT_GT(used.Nodes().size(), size_t(kFaceCount));
    used.Reset();
    EXPECT_EQ(used.Nodes().size(), size_t(kFaceCount));
    ExpectSameLeaves(used.Classify(second), fresh.Classify(second), true);
    ExpectSameNodes(used, fresh);
}

// Leaves write their lists straight into room reserved in the output, twice the last
// generation's lists; lists that find it full go to their thread's own array and are copied
// after the room's. Whether a generation's lists fit, overflow, or both, the leaves are those of
// a fresh hierarchy (whose first generation has no room: every list overflows).
TEST(Hierarchy, ListsThatOutgrowTheirRoomAreTheSame) {
    const scene::Scene s = RandomScene(95, 400, 6, 2);
    const auto small = RandomRays(96, 2000), big = RandomRays(97, 30000);
    Params p = DeepParams(s);
    p.threads = 2;
    p.taskRays = 512;
    Hierarchy used(s, p);
    const LeafBatch first = used.Classify(small);
    size_t firstLists = 0;
    for (const RcLeaf& leaf : first.leaves) firstLists += leaf.candCount;
    // No room: one list after the other.
    EXPECT_EQ(first.candidates.size(), firstLists);
    for (const auto* rays : {&big, &big, &small}) {
        used.Reset();
        Hierarchy fresh(s, p);
        const LeafBatch got = used.Classify(*rays), ref = fresh.Classify(*rays);
        ExpectSameLeaves(got, ref, true);
        ExpectSameHits(Query(s, got, *rays), BruteForce(s, *rays));
    }
    // The big generation's lists outgrow the room the small one left (2 x firstLists): some are
    // claimed in chunks (which leave gaps), the rest overflow.
    used.Reset();
    used.Classify(small);
    used.Reset();
    const LeafBatch mixed = used.Classify(big);
    size_t lists = 0;
    for (const RcLeaf& leaf : mixed.leaves) lists += leaf.candCount;
    ASSERT_GT(lists, 2 * firstLists);
    EXPECT_GT(mixed.candidates.size(), lists) << "no list was claimed in the room";
}

// Nodes with many rays plan their next levels of splits and bucket the rays into the plan's
// cells in one pass. The planned hierarchy keeps every invariant of the plain one: each ray in
// one leaf whose interval contains it, children inside their parents, exact answers, over two
// generations (the second routed through the first's splits). Rays in clusters with gaps between
// them leave planned halves empty, which the planned nodes skip.
TEST(Hierarchy, PlannedSplitsKeepTheInvariantsAndMoveRaysLess) {
    const scene::Scene s = RandomScene(111, 400, 6, 2);
    std::vector<Ray> first = RandomRays(112, 9000);
    std::mt19937 rng(113);
    std::uniform_real_distribution<float> jitter(-0.02f, 0.02f), cone(-0.3f, 0.3f);
    for (int i = 0; i < 3000; ++i) {
        const float clusters[3] = {-0.95f, -0.85f, 0.9f};
        Ray r;
        r.origin = glm::vec3(-1.0f, clusters[i % 3] + jitter(rng), jitter(rng));
        r.direction = glm::normalize(glm::vec3(1.0f, cone(rng), cone(rng)));
        first.push_back(r);
    }
    std::vector<Ray> second = RandomRays(114, 8000);
    uint64_t moves[2] = {};
    for (const uint32_t planRays : {0u, 256u}) {
        SCOPED_TRACE(planRays);
        Params p = DeepParams(s);
        p.planRays = planRays;
        Hierarchy h(s, p);
        for (std::vector<Ray>* rays : {&first, &second}) {
            const LeafBatch batch = h.Classify(*rays);
            if (rays == &first) {
                EXPECT_EQ(h.Counters().plans > 0, planRays > 0);
            }
            moves[planRays > 0] += h.Counters().rayMoves;
            ExpectEveryRayOnce(batch, uint32_t(rays->size()));
            ExpectSameHits(Query(s, batch, *rays), BruteForce(s, *rays));
            for (const RcLeaf& leaf : batch.leaves) {
                for (uint32_t j = 0; j < leaf.rayCount; ++j) {
                    const uint32_t id = batch.rayIndex[leaf.rayBegin + j];
                    Ray5 r;
                    ASSERT_TRUE(ToRay5((*rays)[id], h.SceneBox(), r));
                    ASSERT_TRUE(h.Nodes()[leaf.node].box.Contains(r.p)) << "ray " << id;
                }
            }
        }
        for (const Node& n : h.Nodes()) {
            if (n.IsLeaf()) continue;
            for (uint32_t c : n.child) EXPECT_TRUE(n.box.Contains(h.Nodes()[c].box));
        }
    }
    EXPECT_LT(moves[1], moves[0] * 3 / 4);
}

// A face root with a large share of the rays plans its first splits while the other threads
// wait for work: they share its moves, and the leaves, lists and nodes stay those of one thread.
TEST(Hierarchy, PlansSharedBetweenThreadsGiveTheSameTree) {
    const scene::Scene s = RandomScene(121, 300, 4, 2);
    std::mt19937 rng(122);
    std::uniform_real_distribution<float> cone(-0.9f, 0.9f), jitter(-0.01f, 0.01f);
    std::vector<Ray> rays;  // all in face +x: one root, the only task at first
    for (int i = 0; i < 150000; ++i) {
        Ray r;
        r.origin = glm::vec3(-1.0f, jitter(rng), jitter(rng));
        r.direction = glm::normalize(glm::vec3(1.0f, cone(rng), cone(rng)));
        rays.push_back(r);
    }
    Params serial;
    serial.threads = 1;
    Hierarchy reference(s, serial);
    const LeafBatch ref = reference.Classify(rays);
    EXPECT_EQ(reference.Counters().sharedPlans, 0u);
    ExpectSameHits(Query(s, ref, rays), BruteForce(s, rays));
    for (const uint32_t threads : {2u, 3u}) {
        SCOPED_TRACE(threads);
        Params p;
        p.threads = threads;
        Hierarchy h(s, p);
        const LeafBatch got = h.Classify(rays);
        EXPECT_GT(h.Counters().sharedPlans, 0u);
        ExpectSameLeaves(got, ref, false);
        ExpectSameNodes(h, reference);
    }
}

TEST(Hierarchy, MemoryOfInnerListsIsScratch) {
    const scene::Scene s = RandomScene(71, 300, 0, 0);
    const auto rays = RandomRays(72, 3000);
    Hierarchy h(s, DeepParams(s));
    const LeafBatch batch = h.Classify(rays);
    EXPECT_GT(h.Counters().boxTests, 0u);
    EXPECT_GT(h.Counters().scratchBytes, 0u);
    EXPECT_GT(h.MemoryBytes(), h.Counters().scratchBytes);
    EXPECT_GE(h.Counters().maxDepth, 5u);
}

}  // namespace
}  // namespace rayclass::classify

namespace rayclass::classify {
namespace {

// Issue 3 follow-up: a small group of rays (fewer than minRays) with a long list is split when
// the cost function says so, rather than left as one leaf with the whole list; a small group with
// a short list is not. Both stay exact.
TEST(Hierarchy, CostFunctionSplitsSmallGroupsWithLongLists) {
    const scene::Scene s = RandomScene(51, 6000, 0, 0);
    std::mt19937 rng(52);
    std::uniform_real_distribution<float> pos(-1.0f, 1.0f), slope(-0.9f, 0.9f);
    std::vector<Ray> rays;
    for (int i = 0; i < 48; ++i) {  // all +X rays, spread over the box: one face, one long list
        Ray r;
        r.origin = glm::vec3(-1.1f, pos(rng), pos(rng));
        r.direction = glm::normalize(glm::vec3(1.0f, slope(rng), slope(rng)));
        rays.push_back(r);
    }
    Params p = Params::ForScene(s);
    ASSERT_LT(rays.size(), p.minRays);
    Hierarchy h(s, p);
    const LeafBatch batch = h.Classify(rays);
    ExpectEveryRayOnce(batch, uint32_t(rays.size()));
    EXPECT_GT(batch.leaves.size(), 4u);
    uint32_t longest = 0;
    for (const RcLeaf& leaf : batch.leaves) longest = std::max(longest, leaf.candCount);
    EXPECT_LT(longest, s.PrimitiveCount() / 2) << "leaves " << batch.leaves.size();
    ExpectSameHits(Query(s, batch, rays), BruteForce(s, rays));

    // A small scene: the lists are short, so the same rays stay one leaf.
    const scene::Scene small = RandomScene(53, 40, 0, 0);
    Hierarchy hs(small, Params::ForScene(small));
    const LeafBatch few = hs.Classify(rays);
    EXPECT_EQ(few.leaves.size(), 1u);
    ExpectSameHits(Query(small, few, rays), BruteForce(small, rays));
}

TEST(Hierarchy, AnyHitRaysEndingAtALightAreClassifiedFromIt) {
    const scene::Scene s = RandomScene(61, 400, 6, 3);
    const std::vector<glm::vec3> lights = {
        {0.2f, 0.9f, 0.1f}, {-0.7f, 0.3f, 0.5f}, {0.5f, -0.6f, -0.4f}};
    const std::vector<Ray> rays = ShadowSlots(s, lights, 62, 700);
    uint64_t live = 0;
    for (const Ray& r : rays) live += r.tMax > 0.0f ? 1 : 0;
    const std::vector<bool> truth = BlockedBruteForce(s, rays);
    ASSERT_GT(std::count(truth.begin(), truth.end(), true), 100);
    ASSERT_GT(std::count(truth.begin(), truth.end(), false), 100);

    Hierarchy h(s, DeepParams(s));
    const LeafBatch batch = h.Classify(rays, RayUse::kAnyHit);
    EXPECT_EQ(h.Counters().fromEnd, live);
    ExpectEveryRayOnce(batch, uint32_t(rays.size()));
    EXPECT_EQ(batch.missed.size(), rays.size() - live);  // the empty slots
    // Each leaf holds one light's rays, in the face of their direction from the light.
    for (const RcLeaf& leaf : batch.leaves) {
        for (uint32_t j = 0; j < leaf.rayCount; ++j) {
            const uint32_t id = batch.rayIndex[leaf.rayBegin + j];
            ASSERT_EQ(int(leaf.face), FaceOf(-rays[id].direction)) << "ray " << id;
        }
    }
    EXPECT_EQ(Blocked(s, batch, rays), truth);

    // The same rays as nearest-hit rays are classified as they run: no ray from its end.
    Hierarchy forward(s, DeepParams(s));
    const LeafBatch f = forward.Classify(rays);
    EXPECT_EQ(forward.Counters().fromEnd, 0u);
    for (const RcLeaf& leaf : f.leaves) {
        const uint32_t id = f.rayIndex[leaf.rayBegin];
        EXPECT_EQ(int(leaf.face), FaceOf(rays[id].direction)) << "ray " << id;
    }
    EXPECT_EQ(Blocked(s, f, rays), truth);

    // A light outside the scene box: its rays would start outside and be clipped, so they are
    // classified as they run; the lights inside still are from their end.
    const std::vector<glm::vec3> outside = {{0.2f, 4.0f, 0.1f}, lights[1]};
    const std::vector<Ray> mixed = ShadowSlots(s, outside, 63, 400);
    uint64_t liveInside = 0;
    for (size_t i = 1; i < mixed.size(); i += 2) liveInside += mixed[i].tMax > 0.0f ? 1 : 0;
    const LeafBatch m = h.Classify(mixed, RayUse::kAnyHit);
    EXPECT_EQ(h.Counters().fromEnd, liveInside);
    EXPECT_EQ(Blocked(s, m, mixed), BlockedBruteForce(s, mixed));
}

TEST(Hierarchy, CommonEndsNeedManySegmentsEndingWithinTheTolerance) {
    const Bounds3f box{glm::vec3(-2.0f), glm::vec3(2.0f)};
    const glm::vec3 light(0.5f, 1.0f, -0.25f), lamp(-1.0f, 0.0f, 0.75f);
    std::mt19937 rng(71);
    std::vector<Ray> rays;
    for (int i = 0; i < 1000; ++i) {
        Ray r;
        r.origin = glm::vec3(0.0f, -1.0f, 0.0f) + 0.5f * RandomDirection(rng);
        // Five rays go to the lamp: under 1/32 of the sample, however many it picks.
        const glm::vec3 to = (i % 200 == 7 ? lamp : light) - r.origin;
        r.tMax = glm::length(to);
        r.direction = to / r.tMax;
        rays.push_back(r);
    }
    const float tolerance = 1e-5f;
    const CommonEnds ends = FindCommonEnds(rays, box, tolerance);
    ASSERT_EQ(ends.n, 1);
    EXPECT_LE(glm::length(ends.point[0] - light), tolerance);
    EXPECT_EQ(ends.Match(rays[0]), 0);
    EXPECT_EQ(ends.Match(rays[7]), -1);
    // Taken from the end: starts at the point, runs back along the same segment.
    Ray shifted = rays[0];
    shifted.tMin = 0.25f;
    const Ray o = ends.Oriented(shifted);
    EXPECT_EQ(o.origin, ends.point[0]);
    EXPECT_EQ(o.direction, -shifted.direction);
    EXPECT_EQ(o.tMin, 0.0f);
    EXPECT_EQ(o.tMax, shifted.tMax - 0.25f);
    // An end 3 tolerances off in one coordinate, an unbounded ray and an empty segment: no match.
    Ray off = rays[0];
    off.origin.y += 3.0f * tolerance;
    EXPECT_EQ(ends.Match(off), -1);
    Ray unbounded = rays[0];
    unbounded.tMax = INFINITY;
    EXPECT_EQ(ends.Match(unbounded), -1);
    Ray empty = rays[0];
    empty.tMin = empty.tMax;
    EXPECT_EQ(ends.Match(empty), -1);
    EXPECT_EQ(ends.Oriented(off).origin, off.origin);

    // Every ray to its own end (an area light's samples): no common end. Nor outside the box.
    std::vector<Ray> spread = rays;
    for (Ray& r : spread) r.tMax *= 0.5f + 0.5f * float(&r - spread.data()) / 1000.0f;
    EXPECT_EQ(FindCommonEnds(spread, box, tolerance).n, 0);
    const Bounds3f small{glm::vec3(-2.0f), glm::vec3(0.25f)};
    EXPECT_EQ(FindCommonEnds(rays, small, tolerance).n, 0);
}

}  // namespace
}  // namespace rayclass::classify
