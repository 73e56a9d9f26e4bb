// RayOrder: the order of a generation's rays, checked against what the rays themselves say
// (their directions' signs and cells, their origins' positions) and against the order they came
// in.
#include "ray_order.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <random>
#include <tuple>
#include <vector>

namespace rayclass::render {
namespace {

RcRay MakeRay(float ox, float oy, float oz, float dx, float dy, float dz) {
    RcRay r{};
    r.origin = {ox, oy, oz, 0.0f};
    r.direction = {dx, dy, dz, 1.0f};
    return r;
}

Bounds3f UnitBox() {
    Bounds3f box;
    box.Grow(glm::vec3(0.0f));
    box.Grow(glm::vec3(1.0f));
    return box;
}

// Slots name every second ray (as the renderer's live slots name reflection slots), pixels
// are tied to their slot, so the test sees that both move alike.
struct Live {
    std::vector<uint32_t> slots, pixels;
    explicit Live(size_t n) {
        for (uint32_t i = 0; i < n; ++i) {
            slots.push_back(2 * i);
            pixels.push_back(1000 + 2 * i);
        }
    }
    void ExpectTied() const {
        for (size_t i = 0; i < slots.size(); ++i) EXPECT_EQ(pixels[i], 1000 + slots[i]);
    }
    void ExpectPermutationOf(size_t n) const {
        std::vector<uint32_t> s = slots;
        std::sort(s.begin(), s.end());
        for (uint32_t i = 0; i < n; ++i) ASSERT_EQ(s[i], 2 * i);
    }
};

int Octant(const RcRay& r) {
    return int(std::signbit(r.direction.x)) | int(std::signbit(r.direction.y)) << 1 |
           int(std::signbit(r.direction.z)) << 2;
}

TEST(RayOrder, GroupsRaysByTheOctantOfTheirDirection) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f), p(0.0f, 1.0f);
    const size_t n = 200;
    std::vector<RcRay> rays(2 * n);
    for (RcRay& r : rays) r = MakeRay(p(rng), p(rng), p(rng), u(rng), u(rng), u(rng));
    Live live(n);
    RayOrder order(UnitBox());
    order.Sort(rays, live.slots, live.pixels);
    live.ExpectPermutationOf(n);
    live.ExpectTied();
    for (size_t i = 1; i < n; ++i)
        EXPECT_LE(Octant(rays[live.slots[i - 1]]), Octant(rays[live.slots[i]]));
}

TEST(RayOrder, OrdersRaysOfOneOctantAlongALineByTheirOrigins) {
    // Origins far enough apart to lie in different cells of any grid of 2^4 to 2^10 per axis.
    const std::vector<float> xs = {0.9f, 0.1f, 0.5f, 0.3f, 0.7f, 0.2f};
    std::vector<RcRay> rays(2 * xs.size());
    for (size_t i = 0; i < xs.size(); ++i) rays[2 * i] = MakeRay(xs[i], 0.5f, 0.5f, 1, 1, 1);
    Live live(xs.size());
    RayOrder order(UnitBox());
    order.Sort(rays, live.slots, live.pixels);
    live.ExpectTied();
    for (size_t i = 1; i < xs.size(); ++i)
        EXPECT_LT(rays[live.slots[i - 1]].origin.x, rays[live.slots[i]].origin.x);
}

// The cell of x in [0, 1) on a grid of `cells`, the last cell taking 1.
uint32_t GridCell(float x, int cells) {
    return std::min(uint32_t(x * float(cells)), uint32_t(cells - 1));
}

// Bits of the given coordinates interleaved from the most significant down, the first
// coordinate's bit above the others' at each level: a Morton code built bit by bit.
uint64_t Interleave(const std::vector<uint32_t>& coords, int bits) {
    uint64_t code = 0;
    for (int b = bits - 1; b >= 0; --b)
        for (uint32_t c : coords) code = code << 1 | (c >> b & 1u);
    return code;
}

// The documented order: octant, then the origin's cell on a 32^3 grid (z's bit above y's above
// x's), then the direction's cell on an 8 x 8 grid over its octant's octahedral face (|x| / L1
// above |y| / L1).
std::tuple<int, uint64_t, uint64_t> ExpectedKey(const RcRay& r) {
    const float a[3] = {std::fabs(r.direction.x), std::fabs(r.direction.y),
                        std::fabs(r.direction.z)};
    const float l1 = a[0] + a[1] + a[2];
    const uint64_t origin = Interleave(
        {GridCell(r.origin.z, 32), GridCell(r.origin.y, 32), GridCell(r.origin.x, 32)}, 5);
    const uint64_t direction = Interleave({GridCell(a[0] / l1, 8), GridCell(a[1] / l1, 8)}, 3);
    return {Octant(r), origin, direction};
}

TEST(RayOrder, OrdersRaysByOctantThenOriginCellThenDirectionCell) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f), p(0.0f, 1.0f);
    // Few origin cells (coordinates on a 4-step lattice), so that many rays share one and
    // their directions decide.
    std::uniform_int_distribution<int> lattice(0, 3);
    const size_t n = 4000;
    std::vector<RcRay> rays(2 * n);
    for (RcRay& r : rays)
        r = MakeRay(0.25f * float(lattice(rng)) + 0.01f, 0.25f * float(lattice(rng)) + 0.01f,
                    p(rng), u(rng), u(rng), u(rng));
    Live live(n);
    std::vector<uint32_t> expected = live.slots;
    std::stable_sort(expected.begin(), expected.end(), [&](uint32_t a, uint32_t b) {
        return ExpectedKey(rays[a]) < ExpectedKey(rays[b]);
    });
    RayOrder order(UnitBox());
    order.Sort(rays, live.slots, live.pixels);
    live.ExpectTied();
    EXPECT_EQ(live.slots, expected);
}

TEST(RayOrder, KeepsTheOrderOfRaysThatStartTogetherAndHeadTheSameWay) {
    const size_t n = 50;
    std::vector<RcRay> rays(2 * n, MakeRay(0.25f, 0.5f, 0.75f, -1, 1, 1));
    Live live(n);
    const Live before = live;
    RayOrder order(UnitBox());
    order.Sort(rays, live.slots, live.pixels);
    EXPECT_EQ(live.slots, before.slots);
    EXPECT_EQ(live.pixels, before.pixels);
}

TEST(RayOrder, TakesOriginsOutsideItsBoxAndAnEmptyBox) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    std::vector<RcRay> rays = {MakeRay(-5, 9, 0.5f, 1, 1, 1),  {}, MakeRay(nan, 0, 0, 1, 1, 1), {},
                               MakeRay(2, -3, 1e30f, 1, 1, 1), {}};
    for (const Bounds3f& box : {UnitBox(), Bounds3f{}}) {
        Live live(3);
        RayOrder order(box);
        order.Sort(rays, live.slots, live.pixels);
        live.ExpectPermutationOf(3);
        live.ExpectTied();
    }
}

TEST(RayOrder, OrdersALargeBatchAsAStableSortByOctantThenCell) {
    // Many rays and few distinct keys, so that most keys are shared and the radix passes must
    // keep their order: origins on one line along x (cells of 1/32 of the box, whose Morton
    // order along one axis is their order), directions in two octants with the same direction
    // cell (|x|, |y| and |z| alike).
    std::mt19937 rng(11);
    std::uniform_int_distribution<int> cell(0, 31), octant(0, 1);
    const size_t n = 150000;
    std::vector<RcRay> rays(2 * n);
    std::vector<std::pair<int, int>> key(n);  // (octant, cell) of slot 2i's ray
    for (size_t i = 0; i < n; ++i) {
        const int c = cell(rng), o = octant(rng);
        rays[2 * i] = MakeRay((float(c) + 0.5f) / 32.0f, 0.5f, 0.5f, o ? -1.0f : 1.0f, 1, 1);
        key[i] = {o, c};
    }
    std::vector<uint32_t> expected(n);
    std::iota(expected.begin(), expected.end(), 0u);
    std::stable_sort(expected.begin(), expected.end(),
                     [&](uint32_t a, uint32_t b) { return key[a] < key[b]; });
    Live live(n);
    RayOrder order(UnitBox());
    order.Sort(rays, live.slots, live.pixels);
    live.ExpectTied();
    for (size_t i = 0; i < n; ++i) ASSERT_EQ(live.slots[i], 2 * expected[i]) << i;
}

}  // namespace
}  // namespace rayclass::render
