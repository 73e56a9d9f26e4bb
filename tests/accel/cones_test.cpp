// The enclosing cones of the hierarchical ray engine hold their rays: every origin inside the
// cone and every direction within its half-angle, checked in double on coherent sets (a pinhole's
// tiles, parallel rays from a plane, rays spread from scattered origins) and on sets that must
// come out unbounded (directions over a whole sphere), for the host's construction (which
// decides whether a batch keeps its order) and the device's (the cones the kernels cull with).
#include "rayclass/accel/cones.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "accel_support.h"

namespace rayclass::accel {
namespace {

// How far outside the cone (radians) the worst ray of the set lies; <= 0 when all are inside.
double WorstExcess(const RcCone& c, const std::vector<RcRay>& rays) {
    // The kernels' test depends on the axis' direction only; a float axis is unit only to
    // rounding, which an acos near 1 would turn into 1e-4 radians.
    const glm::dvec3 apex(c.apex.x, c.apex.y, c.apex.z),
        axis = glm::normalize(glm::dvec3(c.axis.x, c.axis.y, c.axis.z));
    const double phi = std::atan(std::sqrt(double(c.apex.w)));
    double worst = -1.0;
    for (const RcRay& r : rays) {
        const glm::dvec3 o(r.origin.x, r.origin.y, r.origin.z);
        const glm::dvec3 d(r.direction.x, r.direction.y, r.direction.z);
        const double toOrigin =
            std::acos(std::clamp(glm::dot(glm::normalize(o - apex), axis), -1.0, 1.0));
        const double dir = std::acos(std::clamp(glm::dot(glm::normalize(d), axis), -1.0, 1.0));
        worst = std::max({worst, toOrigin - phi, dir - phi});
    }
    return worst;
}

RcCone ConeOf(const std::vector<RcRay>& rays) { return EnclosingCone(rays, 1e-6); }

RcRay Ray(glm::vec3 o, glm::vec3 d) {
    d = glm::normalize(d);
    return {{o.x, o.y, o.z, 0.0f}, {d.x, d.y, d.z, INFINITY}};
}

TEST(EnclosingCone, HoldsEveryRayOfCoherentSets) {
    std::mt19937 rng(2);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (int set = 0; set < 200; ++set) {
        std::vector<RcRay> rays;
        const glm::vec3 axis = glm::normalize(glm::vec3(u(rng), u(rng), u(rng)));
        const float spread = set % 3 == 0 ? 0.0f : 0.05f * float(set % 7);
        const float origins = set % 2 == 0 ? 0.0f : 2.0f;
        for (int i = 0; i < 64; ++i) {
            const glm::vec3 o = origins * glm::vec3(u(rng), u(rng), u(rng));
            rays.push_back(Ray(o, axis + spread * glm::vec3(u(rng), u(rng), u(rng))));
        }
        const RcCone c = ConeOf(rays);
        ASSERT_GE(c.apex.w, 0.0f) << "set " << set;  // coherent: a bounded cone
        EXPECT_LE(WorstExcess(c, rays), 0.0) << "set " << set;
    }
}

// Two rays diverging symmetrically by theta from origins 2 apart: step (a) turns the axis to
// their bisector, step (b) slides the apex back along the far generator until the near one
// passes through the second origin, which puts it where the two rays' lines cross, 1 / tan theta
// behind the origins (the construction's least angle, 1e-3, tilts the axis by about half that,
// which moves the apex across by about 0.005, and the margins back it off by far less).
TEST(EnclosingCone, OriginStepPutsTheApexWhereTheGeneratorsCross) {
    const float theta = 0.1f;
    const RcCone c = ConeOf({Ray({1, 0, 0}, {std::sin(theta), 0, std::cos(theta)}),
                             Ray({-1, 0, 0}, {-std::sin(theta), 0, std::cos(theta)})});
    ASSERT_GE(c.apex.w, 0.0f);
    EXPECT_NEAR(c.axis.z, 1.0f, 1e-6f);
    EXPECT_NEAR(c.apex.x, 0.0f, 0.01f);
    EXPECT_NEAR(c.apex.z, -1.0f / std::tan(theta), 0.05f);
    // Far behind the apex and off the axis: only the back-off along the axis reaches it.
    const std::vector<RcRay> behind = {Ray({0, 0, 0}, {0.1f, 0, 1}), Ray({0, 0, 0}, {-0.1f, 0, 1}),
                                       Ray({3, 0, -50}, {0, 0, 1})};
    EXPECT_LE(WorstExcess(ConeOf(behind), behind), 0.0);
}

// The device's cones (cl/cones.cl, in float) hold their rays as the host's do: coherent sets
// of four tiles (pinholes, parallel rays from a plane, spread rays from scattered origins), each
// tile's cone holds its rays, the group's cone every ray of the four.
TEST(DeviceCones, TileAndGroupConesHoldTheirRays) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (int set = 0; set < 100; ++set) {
        const glm::vec3 axis = glm::normalize(glm::vec3(u(rng), u(rng), u(rng)));
        const float spread = 0.02f * float(set % 5), origins = set % 2 == 0 ? 0.0f : 2.0f;
        const float tilt = set % 3 == 0 ? 0.0f : 0.1f;
        std::vector<RcRay> rays;
        for (int t = 0; t < 4; ++t) {
            const glm::vec3 tileAxis = axis + tilt * glm::vec3(u(rng), u(rng), u(rng));
            for (uint32_t i = 0; i < kConeTileRays; ++i) {
                const glm::vec3 o = origins * glm::vec3(u(rng), u(rng), u(rng));
                rays.push_back(Ray(o, tileAxis + spread * glm::vec3(u(rng), u(rng), u(rng))));
            }
        }
        const render::ConeLevels c = render::BuildCones(Ctx(), Program(), rays, 1e-6);
        ASSERT_EQ(c.tiles.size(), 4u);
        ASSERT_EQ(c.groups.size(), 1u);
        for (size_t t = 0; t < 4; ++t) {
            const std::vector<RcRay> tile(rays.begin() + t * kConeTileRays,
                                          rays.begin() + (t + 1) * kConeTileRays);
            ASSERT_GE(c.tiles[t].apex.w, 0.0f) << "set " << set << " tile " << t;
            EXPECT_LE(WorstExcess(c.tiles[t], tile), 0.0) << "set " << set << " tile " << t;
        }
        ASSERT_GE(c.groups[0].apex.w, 0.0f) << "set " << set;
        EXPECT_LE(WorstExcess(c.groups[0], rays), 0.0) << "set " << set;
    }
}

// Directions over a whole sphere, or two opposite ones, make an unbounded tile cone on the
// device too, and so an unbounded group; a batch's last tile and group may be short.
TEST(DeviceCones, WideTilesAreUnboundedAndShortTilesCount) {
    std::mt19937 rng(4);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::vector<RcRay> rays;
    for (uint32_t i = 0; i < kConeTileRays; ++i) {
        rays.push_back(Ray({0, 0, 0}, {u(rng), u(rng), u(rng)}));
    }
    rays.push_back(Ray({0, 0, 0}, {1, 0, 0}));
    rays.push_back(Ray({0, 0, 0}, {-1, 0, 0}));
    const render::ConeLevels c = render::BuildCones(Ctx(), Program(), rays, 1e-6);
    ASSERT_EQ(c.tiles.size(), 2u);
    ASSERT_EQ(c.groups.size(), 1u);
    EXPECT_LT(c.tiles[0].apex.w, 0.0f);
    EXPECT_LT(c.tiles[1].apex.w, 0.0f);
    EXPECT_LT(c.groups[0].apex.w, 0.0f);
}

// A pinhole's rays in scanline order (rows of 1024 pixels over 40 degrees: a tile, 64 of them,
// spans 2.4 degrees) keep their order; the same rays shuffled do not.
TEST(CoherentAsGiven, ScanlinesAreCoherentShuffledRaysAreNot) {
    std::vector<RcRay> rays;
    for (int y = 0; y < 16; ++y) {
        for (int x = 0; x < 1024; ++x) {
            const float u = (float(x) / 1023.0f - 0.5f) * 0.7f,
                        v = (float(y) / 15.0f - 0.5f) * 0.2f;
            rays.push_back(Ray({0, 0, 0}, {u, v, 1}));
        }
    }
    EXPECT_TRUE(CoherentAsGiven(rays));
    std::mt19937 rng(5);
    std::shuffle(rays.begin(), rays.end(), rng);
    EXPECT_FALSE(CoherentAsGiven(rays));
}

TEST(EnclosingCone, DirectionsOverTheWholeSphereAreUnbounded) {
    std::mt19937 rng(4);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::vector<RcRay> rays;
    for (int i = 0; i < 64; ++i) rays.push_back(Ray({0, 0, 0}, {u(rng), u(rng), u(rng)}));
    EXPECT_LT(ConeOf(rays).apex.w, 0.0f);
    // Two opposite directions: the paper's step (a) would divide by zero.
    EXPECT_LT(ConeOf({Ray({0, 0, 0}, {1, 0, 0}), Ray({0, 0, 0}, {-1, 0, 0})}).apex.w, 0.0f);
}

}  // namespace
}  // namespace rayclass::accel
