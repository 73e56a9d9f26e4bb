// The candidate filter on 16-bit boxes (src/classify/filter.h) against the beam test in double
// precision on the boxes before they were rounded to steps: it may keep more, never less.
#include "filter.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace rayclass::classify {
namespace {

struct WorldBox {
    float lo[3], hi[3];
};

// Whether some ray of `beam` (origins in its X, Y, Z box, slopes in its u, v box, travelling at
// most `reach` along X) meets `b`, in double: the real-arithmetic test of filter.h's comment.
bool ExactMayReach(const Box5& beam, double reach, const WorldBox& b) {
    double lo = std::max(double(b.lo[0]) - beam.hi[0], 0.0);
    double hi = std::min(double(b.hi[0]) - beam.lo[0], reach);
    // slope * s >= below and slope' * s <= above, for the slope bounds of one axis.
    auto side = [&](double slope, double bound, bool atLeast) {
        if (slope == 0.0) {
            if (atLeast ? bound > 0.0 : bound < 0.0) hi = -1.0;  // no s >= 0 satisfies it
            return;
        }
        const double s = bound / slope;
        if ((slope > 0.0) == atLeast) {
            lo = std::max(lo, s);
        } else {
            hi = std::min(hi, s);
        }
    };
    side(beam.hi[3], double(b.lo[1]) - beam.hi[1], true);
    side(beam.lo[3], double(b.hi[1]) - beam.lo[1], false);
    side(beam.hi[4], double(b.lo[2]) - beam.hi[2], true);
    side(beam.lo[4], double(b.hi[2]) - beam.lo[2], false);
    return lo <= hi;
}

struct QuantizedList {
    ListFrame frame;
    FaceList list;
    std::vector<WorldBox> world;  // in list order (sorted by near X)
};

// q's world boxes sorted by near X, and its list from them in q's frame, as the face lists
// quantize them; ids are positions.
void FillSteps(QuantizedList& q) {
    std::sort(q.world.begin(), q.world.end(),
              [](const WorldBox& a, const WorldBox& b) { return a.lo[0] < b.lo[0]; });
    uint16_t* const l[3] = {q.list.x0.data(), q.list.y0.data(), q.list.z0.data()};
    uint16_t* const h[3] = {q.list.x1.data(), q.list.y1.data(), q.list.z1.data()};
    for (size_t i = 0; i < q.world.size(); ++i) {
        for (int k = 0; k < 3; ++k) {
            l[k][i] = StepsBelow(q.frame, k, q.world[i].lo[k]);
            h[k][i] = StepsAbove(q.frame, k, q.world[i].hi[k]);
        }
        q.list.prim[i] = uint32_t(i);
    }
}

// n random boxes around [-4, 6]^3: from points (zero extent) to wide ones, some touching the
// frame's bounds, quantized as the face lists are.
QuantizedList RandomList(std::mt19937& rng, size_t n) {
    std::uniform_real_distribution<float> pos(-4.0f, 6.0f), size(0.0f, 1.5f);
    std::bernoulli_distribution point(0.1);
    QuantizedList q;
    q.world.resize(n);
    for (WorldBox& b : q.world) {
        for (int k = 0; k < 3; ++k) {
            b.lo[k] = pos(rng);
            b.hi[k] = point(rng) ? b.lo[k] : b.lo[k] + size(rng);
        }
    }
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (const WorldBox& b : q.world) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], b.lo[k]);
            hi[k] = std::max(hi[k], b.hi[k]);
        }
    }
    q.frame = MakeListFrame(lo, hi);
    q.list.Resize(n);
    FillSteps(q);
    return q;
}

// A random beam: an origin box inside the boxes' range and slopes in [-1, 1], some bounds exactly
// zero (the filter widens those).
Box5 RandomBeam(std::mt19937& rng) {
    std::uniform_real_distribution<float> pos(-4.0f, 6.0f), size(0.0f, 2.0f), slope(-1.0f, 1.0f);
    std::bernoulli_distribution zero(0.15);
    Box5 b;
    for (int k = 0; k < 3; ++k) {
        b.lo[k] = pos(rng);
        b.hi[k] = b.lo[k] + size(rng);
    }
    for (int k = 3; k < 5; ++k) {
        float a = zero(rng) ? 0.0f : slope(rng), c = zero(rng) ? 0.0f : slope(rng);
        if (a > c) std::swap(a, c);
        b.lo[k] = a;
        b.hi[k] = c;
    }
    return b;
}

// A beam that only grazes box b: its origins touch one side of b (or end where b starts, along
// X) and its slopes on that axis start at zero, so a box rounded inwards by any amount is missed.
Box5 GrazingBeam(std::mt19937& rng, const WorldBox& b, int variant) {
    std::uniform_real_distribution<float> size(0.01f, 1.0f), slope(0.05f, 1.0f);
    Box5 beam;
    for (int k = 0; k < 3; ++k) {
        beam.lo[k] = b.lo[k] - size(rng);
        beam.hi[k] = b.hi[k] + size(rng);
    }
    beam.lo[3] = -slope(rng);
    beam.hi[3] = slope(rng);
    beam.lo[4] = -slope(rng);
    beam.hi[4] = slope(rng);
    const int axis = 1 + (variant >> 1) % 2;  // Y or Z
    if (variant == 4) {
        beam.lo[0] = b.hi[0];  // origins start where the box ends along X
    } else if (variant & 1) {
        beam.lo[axis] = b.hi[axis];  // origins above the box, slopes rising from zero
        beam.hi[axis] = b.hi[axis] + size(rng);
        beam.lo[axis + 2] = 0.0f;
    } else {
        beam.hi[axis] = b.lo[axis];  // origins below it, slopes falling to zero
        beam.lo[axis] = b.lo[axis] - size(rng);
        beam.hi[axis + 2] = 0.0f;
    }
    return beam;
}

// The entries of the first n of q's list that the scalar test of t keeps.
std::vector<uint32_t> ScalarKept(const BeamTest& t, const QuantizedList& q, size_t n) {
    std::vector<uint32_t> kept;
    for (size_t i = 0; i < n; ++i) {
        if (BeamMayReach(t, q.list.x0[i], q.list.x1[i], q.list.y0[i], q.list.y1[i], q.list.z0[i],
                         q.list.z1[i]))
            kept.push_back(q.list.prim[i]);
    }
    return kept;
}

TEST(Filter, KeepsEveryBoxTheBeamMeetsAndMatchesTheScalarTest) {
    std::mt19937 rng(11);
    size_t met = 0, kept = 0;
    for (int trial = 0; trial < 200; ++trial) {
        // Lengths around the vector width, with a tail.
        const size_t n = size_t(1 + trial % 53) * (trial % 4 == 0 ? 37 : 1);
        const QuantizedList q = RandomList(rng, n);
        const Box5 beam = trial % 2 ? RandomBeam(rng)
                                    : GrazingBeam(rng, q.world[size_t(trial) % n], (trial / 2) % 5);
        const float reach = std::uniform_real_distribution<float>(0.01f, 12.0f)(rng);
        const BeamTest t = MakeBeamTest(q.frame, beam, reach);
        FaceList out;
        out.Resize(n);
        const size_t k = FilterList(t, View(q.list, n, &q.frame), Out(out, 0));
        // The kept boxes, in order: exactly those the scalar test keeps (RandomList's ids are
        // the entries' positions).
        const std::vector<uint32_t> scalar = ScalarKept(t, q, n);
        ASSERT_EQ(std::vector<uint32_t>(out.prim.begin(), out.prim.begin() + long(k)), scalar)
            << "trial " << trial;
        for (size_t j = 0; j < k; ++j) {
            const uint32_t i = out.prim[j];
            ASSERT_EQ(out.x0[j], q.list.x0[i]);
            ASSERT_EQ(out.x1[j], q.list.x1[i]);
            ASSERT_EQ(out.y0[j], q.list.y0[i]);
            ASSERT_EQ(out.y1[j], q.list.y1[i]);
            ASSERT_EQ(out.z0[j], q.list.z0[i]);
            ASSERT_EQ(out.z1[j], q.list.z1[i]);
        }
        // Conservative: every box the exact test says the beam meets is kept.
        size_t next = 0;
        for (size_t i = 0; i < n; ++i) {
            const bool exact = ExactMayReach(beam, reach, q.world[i]);
            while (next < scalar.size() && scalar[next] < i) ++next;
            const bool isKept = next < scalar.size() && scalar[next] == i;
            EXPECT_TRUE(!exact || isKept) << "trial " << trial << ", box " << i;
            met += exact ? 1 : 0;
        }
        kept += k;
    }
    // The trials test something: beams that meet some boxes and miss others.
    EXPECT_GT(met, 1000u);
    EXPECT_LT(kept, 3 * met);
}

TEST(Filter, PairKeepsForEachBeamWhatTheScalarTestKeeps) {
    std::mt19937 rng(23);
    size_t sameSigns = 0;
    for (int trial = 0; trial < 200; ++trial) {
        const size_t n = size_t(1 + trial % 53) * (trial % 4 == 0 ? 37 : 1);
        const QuantizedList q = RandomList(rng, n);
        // A beam and, on most trials, a sibling of the same origins and slopes' signs (the
        // halves of a node); else an unrelated beam.
        Box5 beam[2] = {RandomBeam(rng), RandomBeam(rng)};
        if (trial % 3 != 0) {
            beam[1] = beam[0];
            for (int k = 3; k < 5; ++k) {
                beam[1].lo[k] = beam[0].lo[k] * 0.5f;
                beam[1].hi[k] = beam[0].hi[k] * 0.75f;
            }
        }
        const float reach = std::uniform_real_distribution<float>(0.01f, 12.0f)(rng);
        BeamTest t[2];
        FaceList outs[2];
        ListOut out[2];
        for (int j = 0; j < 2; ++j) {
            t[j] = MakeBeamTest(q.frame, beam[j], reach);
            outs[j].Resize(n);
            out[j] = Out(outs[j], 0);
        }
        sameSigns += t[0].signs == t[1].signs ? 1 : 0;
        size_t kept[2];
        FilterPair(t, View(q.list, n, &q.frame), out, kept);
        for (int j = 0; j < 2; ++j) {
            std::vector<uint32_t> scalar;
            for (size_t i = 0; i < n; ++i) {
                if (BeamMayReach(t[j], q.list.x0[i], q.list.x1[i], q.list.y0[i], q.list.y1[i],
                                 q.list.z0[i], q.list.z1[i]))
                    scalar.push_back(uint32_t(i));
            }
            ASSERT_EQ(
                std::vector<uint32_t>(outs[j].prim.begin(), outs[j].prim.begin() + long(kept[j])),
                scalar)
                << "trial " << trial << ", beam " << j;
            for (size_t k = 0; k < kept[j]; ++k) {
                const uint32_t i = outs[j].prim[k];
                ASSERT_EQ(outs[j].x0[k], q.list.x0[i]);
                ASSERT_EQ(outs[j].x1[k], q.list.x1[i]);
                ASSERT_EQ(outs[j].y0[k], q.list.y0[i]);
                ASSERT_EQ(outs[j].y1[k], q.list.y1[i]);
                ASSERT_EQ(outs[j].z0[k], q.list.z0[i]);
                ASSERT_EQ(outs[j].z1[k], q.list.z1[i]);
            }
        }
    }
    // Both the one-pass path (same signs) and the fallback run.
    EXPECT_GT(sameSigns, 50u);
    EXPECT_LT(sameSigns, 200u);
}

// n small boxes along a line through [-4, 6]^3, sorted by near X: consecutive entries lie close
// in Y and Z too, so blocks of them have small boxes that narrow beams miss (as the face lists of
// a scene's meshes do).
QuantizedList LineList(std::mt19937& rng, size_t n) {
    QuantizedList q = RandomList(rng, n);
    std::uniform_real_distribution<float> along(0.0f, 1.0f), jitter(-0.2f, 0.2f), size(0.0f, 0.3f);
    for (WorldBox& b : q.world) {
        const float t = along(rng);
        const float at[3] = {-4.0f + 10.0f * t, 6.0f - 10.0f * t, -4.0f + 10.0f * t * t};
        for (int k = 0; k < 3; ++k) {
            b.lo[k] = at[k] + jitter(rng);
            b.hi[k] = b.lo[k] + size(rng);
        }
    }
    FillSteps(q);
    return q;
}

// A block summary holds each block's least lower and greatest upper bounds (a plain loop is the
// oracle), and filters of a summarised list, whole or cut short, keep exactly what the scalar
// test keeps from its entries, in order, for one beam and for a pair.
TEST(Filter, BlockSummariesBoundTheirBlocksAndFiltersThatSkipBlocksKeepWhatTheScalarTestKeeps) {
    std::mt19937 rng(17);
    size_t missedBlocks = 0, blocksTested = 0;
    for (int trial = 0; trial < 120; ++trial) {
        const size_t n = size_t(1 + trial % 29) * (trial % 3 == 0 ? 97 : 13);
        const QuantizedList q = trial % 4 == 0 ? RandomList(rng, n) : LineList(rng, n);
        FaceList blocks;
        blocks.Resize(BlockCount(n));
        FillBlocks(View(q.list, n, &q.frame), Out(blocks, 0));
        const uint16_t* const lower[3] = {q.list.x0.data(), q.list.y0.data(), q.list.z0.data()};
        const uint16_t* const upper[3] = {q.list.x1.data(), q.list.y1.data(), q.list.z1.data()};
        const uint16_t* const lo[3] = {blocks.x0.data(), blocks.y0.data(), blocks.z0.data()};
        const uint16_t* const hi[3] = {blocks.x1.data(), blocks.y1.data(), blocks.z1.data()};
        for (size_t b = 0; b < BlockCount(n); ++b) {
            for (int k = 0; k < 3; ++k) {
                uint16_t least = 65535, greatest = 0;
                for (size_t i = b * kListBlock; i < std::min(n, (b + 1) * kListBlock); ++i) {
                    least = std::min(least, lower[k][i]);
                    greatest = std::max(greatest, upper[k][i]);
                }
                ASSERT_EQ(lo[k][b], least) << "trial " << trial << ", block " << b;
                ASSERT_EQ(hi[k][b], greatest) << "trial " << trial << ", block " << b;
            }
        }
        // Narrow beams (some slopes exactly zero), a list cut short on some trials.
        Box5 beam[2] = {RandomBeam(rng), RandomBeam(rng)};
        for (Box5& b : beam) {
            for (int k = 3; k < 5; ++k) b.hi[k] = b.lo[k] + (b.hi[k] - b.lo[k]) * 0.1f;
        }
        beam[1].lo[3] = beam[0].lo[3];  // often the same signs: the pair's one-pass path
        beam[1].hi[3] = beam[0].hi[3];
        const float reach = std::uniform_real_distribution<float>(0.5f, 12.0f)(rng);
        ListView view = View(q.list, trial % 5 == 1 ? n - n / 3 : n, &q.frame);
        view.blocks = BlocksOf(blocks);
        BeamTest t[2];
        FaceList outs[2];
        ListOut out[2];
        for (int j = 0; j < 2; ++j) {
            t[j] = MakeBeamTest(q.frame, beam[j], reach);
            outs[j].Resize(n);
            out[j] = Out(outs[j], 0);
        }
        const size_t k = FilterList(t[0], view, out[0]);
        ASSERT_EQ(std::vector<uint32_t>(outs[0].prim.begin(), outs[0].prim.begin() + long(k)),
                  ScalarKept(t[0], q, view.n))
            << "trial " << trial;
        size_t kept[2];
        FilterPair(t, view, out, kept);
        for (int j = 0; j < 2; ++j) {
            ASSERT_EQ(
                std::vector<uint32_t>(outs[j].prim.begin(), outs[j].prim.begin() + long(kept[j])),
                ScalarKept(t[j], q, view.n))
                << "trial " << trial << ", beam " << j;
            for (size_t e = 0; e < kept[j]; ++e) {
                const uint32_t i = outs[j].prim[e];
                ASSERT_EQ(outs[j].y1[e], q.list.y1[i]);
                ASSERT_EQ(outs[j].z0[e], q.list.z0[i]);
            }
        }
        for (size_t b = 0; b < BlockCount(view.n); ++b) {
            missedBlocks +=
                BeamMayReach(t[0], lo[0][b], hi[0][b], lo[1][b], hi[1][b], lo[2][b], hi[2][b]) ? 0
                                                                                               : 1;
            ++blocksTested;
        }
    }
    // The beams miss many blocks (the filters skip them) and reach others.
    EXPECT_GT(missedBlocks, blocksTested / 4);
    EXPECT_LT(missedBlocks, blocksTested);
}

TEST(Filter, StepsRoundOutwardsAndTheNearXOfACandidateNeverExceedsItsBox) {
    std::mt19937 rng(12);
    const QuantizedList q = RandomList(rng, 5000);
    for (size_t i = 0; i < q.world.size(); ++i) {
        const WorldBox& b = q.world[i];
        const uint16_t* const l[3] = {q.list.x0.data(), q.list.y0.data(), q.list.z0.data()};
        const uint16_t* const h[3] = {q.list.x1.data(), q.list.y1.data(), q.list.z1.data()};
        for (int k = 0; k < 3; ++k) {
            ASSERT_LE(double(q.frame.base[k]) + double(l[k][i]) * q.frame.step, double(b.lo[k]));
            ASSERT_GE(double(q.frame.base[k]) + double(h[k][i]) * q.frame.step, double(b.hi[k]));
            // One step of slack at most.
            ASSERT_GT(double(q.frame.base[k]) + double(l[k][i] + 1) * q.frame.step,
                      double(b.lo[k]));
        }
        ASSERT_LE(WorldBelow(q.frame, 0, q.list.x0[i]), b.lo[0]);
    }
    // The highest bound fits in 16 bits without clamping: the frame spans the boxes.
    const uint16_t* const h[3] = {q.list.x1.data(), q.list.y1.data(), q.list.z1.data()};
    uint16_t top = 0;
    for (int k = 0; k < 3; ++k) top = std::max(top, *std::max_element(h[k], h[k] + 5000));
    EXPECT_GE(top, 65533);
    EXPECT_LE(top, 65534);
}

TEST(Filter, CutAtTheEndKeepsEveryBoxStartingBeforeIt) {
    std::mt19937 rng(13);
    const QuantizedList q = RandomList(rng, 3000);
    const ListView view = View(q.list, q.world.size(), &q.frame);
    std::uniform_real_distribution<float> end(-5.0f, 8.0f);
    for (int trial = 0; trial < 500; ++trial) {
        // Ends on a box's near X exactly as well as anywhere.
        const float endHi = trial % 2 ? q.world[size_t(trial) % q.world.size()].lo[0] : end(rng);
        const size_t n = CountUpTo(view, endHi);
        const size_t exact = size_t(std::count_if(
            q.world.begin(), q.world.end(), [&](const WorldBox& b) { return b.lo[0] <= endHi; }));
        ASSERT_GE(n, exact) << "end " << endHi;
        // At most the boxes within a step of the end come along.
        const size_t slack =
            size_t(std::count_if(q.world.begin(), q.world.end(), [&](const WorldBox& b) {
                return b.lo[0] <= endHi + 2.0f * q.frame.step;
            }));
        ASSERT_LE(n, slack) << "end " << endHi;
    }
    // An end at the boxes' far side or beyond (CountUpTo's shortcut) keeps them all.
    float far = -INFINITY;
    for (const WorldBox& b : q.world) far = std::max(far, b.hi[0]);
    for (const float endHi : {far, std::nextafter(far, INFINITY), 2.0f * far, INFINITY}) {
        EXPECT_EQ(CountUpTo(view, endHi), q.world.size()) << "end " << endHi;
    }
}

// The set-up's list fill (16 boxes at a time where the vector path exists) against BoxInFace and
// the scalar StepsBelow/StepsAbove, bit for bit, on every face: boxes in a shuffled order, a
// count that leaves a tail, and a frame narrower than some boxes so that both clamps bite.
TEST(Filter, FaceListFillEqualsTheScalarStepsOnEveryFace) {
    std::mt19937 rng(14);
    std::uniform_real_distribution<float> pos(-3.0f, 5.0f), size(0.0f, 0.7f);
    const size_t n = 1000 + 9;
    std::vector<Bounds3f> boxes(n);
    for (Bounds3f& b : boxes) {
        b.lo = glm::vec3(pos(rng), pos(rng), pos(rng));
        b.hi = b.lo + glm::vec3(size(rng), size(rng), size(rng));
    }
    std::vector<uint32_t> order(n);
    for (uint32_t i = 0; i < n; ++i) order[i] = i;
    std::shuffle(order.begin(), order.end(), rng);
    for (int face = 0; face < kFaceCount; ++face) {
        const float lo[3] = {-2.0f, -2.5f, -1.0f}, hi[3] = {4.0f, 3.0f, 4.5f};
        const ListFrame frame = MakeListFrame(lo, hi);
        FaceList l;
        l.Resize(n);
        FillFaceList(face, frame, boxes.data(), order.data(), n, Out(l, 0));
        const uint16_t* const got[6] = {l.x0.data(), l.x1.data(), l.y0.data(),
                                        l.y1.data(), l.z0.data(), l.z1.data()};
        size_t clamped = 0;
        for (size_t i = 0; i < n; ++i) {
            ASSERT_EQ(l.prim[i], order[i]);
            const Box5 b = BoxInFace(face, boxes[order[i]]);
            for (int k = 0; k < 3; ++k) {
                const uint16_t below = StepsBelow(frame, k, b.lo[k]);
                const uint16_t above = StepsAbove(frame, k, b.hi[k]);
                ASSERT_EQ(got[2 * k][i], below) << "face " << face << " entry " << i;
                ASSERT_EQ(got[2 * k + 1][i], above) << "face " << face << " entry " << i;
                clamped += (below == 0) + (above == 65535);
            }
        }
        EXPECT_GT(clamped, 10u) << "face " << face;
    }
}

// A leaf's candidates (16 at a time where the vector path exists) carry the near X that one
// correctly rounded multiply-add of the stored steps gives: glibc's fmaf is the oracle.
TEST(Filter, CandidatesCarryTheFusedNearX) {
    std::mt19937 rng(15);
    std::uniform_int_distribution<int> steps(0, 65535);
    const size_t n = 16 * 40 + 7;
    FaceList l;
    l.Resize(n);
    for (size_t i = 0; i < n; ++i) {
        l.x0[i] = uint16_t(steps(rng));
        l.prim[i] = uint32_t(rng());
    }
    const float lo[3] = {-1234.5f, 0.0f, 0.0f}, hi[3] = {987.25f, 1.0f, 1.0f};
    const ListFrame frame = MakeListFrame(lo, hi);
    std::vector<RcCandidate> out(n);
    WriteCandidates(View(l, n, &frame), n, out.data());
    for (size_t i = 0; i < n; ++i) {
        ASSERT_EQ(out[i].prim, l.prim[i]) << i;
        ASSERT_EQ(out[i].nearX, fmaf(float(l.x0[i]), frame.step, frame.base[0])) << i;
    }
}

TEST(Filter, FramesOfPointsAndEmptySetsAreUsable) {
    const float p[3] = {2.0f, -3.0f, 0.5f};
    const ListFrame point = MakeListFrame(p, p);
    EXPECT_GT(point.step, 0.0f);
    for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(StepsBelow(point, k, p[k]), 0);
        EXPECT_EQ(StepsAbove(point, k, p[k]), 0);
    }
    const float lo[3] = {1.0f, 1.0f, 1.0f}, hi[3] = {0.0f, 0.0f, 0.0f};
    const ListFrame empty = MakeListFrame(lo, hi);
    EXPECT_EQ(empty.step, 1.0f);
}

}  // namespace
}  // namespace rayclass::classify
