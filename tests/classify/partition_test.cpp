// The ray moves of the hierarchy (partition.h) against plain loops: seeded random nodes of every
// length around the 16-lane blocks, at offsets that put a block's stores before the node.
#include "partition.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace rayclass::classify {
namespace {

constexpr float kUnwritten = -12345.0f;
constexpr uint32_t kUnwrittenId = 0xDEADBEEFu;

// Ping-pong buffers of n rays: coordinates from a few repeated values (ties with the split value;
// Convert keeps non-finite rays out of the hierarchy), ids in order; the destination filled with
// a sentinel.
struct Buffers {
    ScratchVector<float> from[kCoords], to[kCoords];
    ScratchVector<uint32_t> fromId, toId;

    Buffers(uint32_t n, std::mt19937& rng) : fromId(n), toId(n) {
        std::uniform_int_distribution<int> pick(0, 32);
        for (int k = 0; k < kCoords; ++k) {
            from[k].resize(n);
            to[k].assign(n, kUnwritten);
            for (uint32_t i = 0; i < n; ++i) {
                from[k][i] = float(pick(rng)) / 8.0f - 2.0f;
            }
        }
        for (uint32_t i = 0; i < n; ++i) fromId[i] = i;
        std::fill(toId.begin(), toId.end(), kUnwrittenId);
    }
    PartitionIo Io(int keyDim) {
        PartitionIo io = Between(from, to, fromId, toId);
        io.key = from[keyDim].data();
        return io;
    }
};

// Expects lo and hi to be the bounds of coordinate k over the source rays `ids`.
void Expect(const std::vector<uint32_t>& ids, const Buffers& b, int k, float lo, float hi) {
    float l = INFINITY, h = -INFINITY;
    for (uint32_t id : ids) {
        const float x = b.from[k][id];
        l = std::min(l, x);
        h = std::max(h, x);
    }
    EXPECT_EQ(lo, l) << "coordinate " << k;
    EXPECT_EQ(hi, h) << "coordinate " << k;
}

TEST(PartitionRays, MovesEachSideAndGathersItsBounds) {
    std::mt19937 rng(11);
    const int masks[] = {63, 56, 24, 1};
    for (uint32_t count : {1u, 5u, 15u, 16u, 17u, 31u, 40u, 64u, 100u, 333u}) {
        for (uint32_t begin : {0u, 3u, 21u}) {
            for (int active : masks) {
                const uint32_t end = begin + count, n = end + 7;
                Buffers b(n, rng);
                const int keyDim = int(rng() % kCoords);
                const float value = float(int(rng() % 33)) / 8.0f - 2.0f;
                Bounds6 left{}, right{};
                const uint32_t mid =
                    PartitionRays(active, b.Io(keyDim), value, begin, end, left, right);
                SCOPED_TRACE(testing::Message() << "count " << count << " begin " << begin
                                                << " active " << active << " value " << value);
                // The rays below the value first, in ray order; the others after them.
                std::vector<uint32_t> wantLeft, wantRight;
                for (uint32_t i = begin; i < end; ++i)
                    (b.from[keyDim][i] < value ? wantLeft : wantRight).push_back(i);
                ASSERT_EQ(mid, begin + wantLeft.size());
                const std::vector<uint32_t> gotLeft(b.toId.begin() + begin, b.toId.begin() + mid);
                EXPECT_EQ(gotLeft, wantLeft);
                std::vector<uint32_t> gotRight(b.toId.begin() + mid, b.toId.begin() + end);
                std::sort(gotRight.begin(), gotRight.end());
                EXPECT_EQ(gotRight, wantRight);
                // Each moved coordinate travels with its id; nothing else is written.
                for (uint32_t i = 0; i < n; ++i) {
                    const bool inside = i >= begin && i < end;
                    if (!inside) {
                        EXPECT_EQ(b.toId[i], kUnwrittenId) << "slot " << i;
                    }
                    for (int k = 0; k < kCoords; ++k) {
                        const float got = b.to[k][i];
                        if (!inside || !((active >> k) & 1)) {
                            EXPECT_EQ(got, kUnwritten) << "slot " << i << " coordinate " << k;
                        } else {
                            EXPECT_EQ(got, b.from[k][b.toId[i]])
                                << "slot " << i << " coordinate " << k;
                        }
                    }
                }
                for (int k = 0; k < kCoords; ++k) {
                    if (!((active >> k) & 1)) continue;
                    Expect(wantLeft, b, k, left.lo[k], left.hi[k]);
                    Expect(wantRight, b, k, right.lo[k], right.hi[k]);
                }
            }
        }
    }
}

// The cell of ray i under `rule`, as BucketRays's documentation defines it.
int CellOf(const Buffers& b, const CellRule& rule, uint32_t i) {
    int h = 0;
    for (int l = 0; l < rule.levels; ++l)
        h = 2 * h + (b.from[rule.dim[l]][i] < rule.value[h] ? 1 : 2);
    return h - ((1 << rule.levels) - 1);
}

TEST(BucketRays, PutsEachCellsRaysInRayOrderForAnyNumberOfPieces) {
    std::mt19937 rng(12);
    const int dim[4] = {3, 4, 0, 5};
    float value[15];
    for (float& v : value) v = float(int(rng() % 33)) / 8.0f - 2.0f;
    bool active[kCoords] = {true, false, true, true, true, true};
    for (int levels : {1, 2, 4}) {
        for (uint32_t count : {1u, 16u, 37u, 1000u}) {
            const uint32_t begin = 5, end = begin + count;
            const CellRule rule{levels, dim, value};
            const int nCells = 1 << levels;
            for (int pieces : {1, 3}) {
                std::mt19937 same(uint32_t(count * 7 + uint32_t(levels)));
                Buffers b(end + 3, same);
                uint32_t cellBegin[17];
                Bounds6 cell[16];
                BucketRays(b.Io(0), active, rule, begin, end, cellBegin, cell, pieces);
                SCOPED_TRACE(testing::Message()
                             << "levels " << levels << " count " << count << " pieces " << pieces);
                std::vector<std::vector<uint32_t>> want(static_cast<size_t>(nCells));
                for (uint32_t i = begin; i < end; ++i)
                    want[size_t(CellOf(b, rule, i))].push_back(i);
                ASSERT_EQ(cellBegin[0], begin);
                for (int c = 0; c < nCells; ++c) {
                    ASSERT_EQ(cellBegin[c + 1] - cellBegin[c], want[size_t(c)].size())
                        << "cell " << c;
                    const std::vector<uint32_t> got(b.toId.begin() + cellBegin[c],
                                                    b.toId.begin() + cellBegin[c + 1]);
                    EXPECT_EQ(got, want[size_t(c)]) << "cell " << c;
                    for (int k = 0; k < kCoords; ++k) {
                        if (!active[k]) continue;
                        if (want[size_t(c)].empty()) {
                            EXPECT_GT(cell[c].lo[k], cell[c].hi[k]) << "empty cell " << c;
                        } else {
                            Expect(want[size_t(c)], b, k, cell[c].lo[k], cell[c].hi[k]);
                        }
                    }
                }
                for (uint32_t i = begin; i < end; ++i) {
                    EXPECT_EQ(b.to[1][i], kUnwritten) << "inactive coordinate, slot " << i;
                    EXPECT_EQ(b.to[3][i], b.from[3][b.toId[i]]) << "slot " << i;
                }
            }
        }
    }
}

}  // namespace
}  // namespace rayclass::classify
