// Constructed scenes where hull projection is easy to get wrong: edge-on triangles, sub-pixel
// spheres, objects behind or around the camera, geometry crossing the near plane (near the eye or
// passing beside it), and more than 2^16 primitives. Every case must give the kernel path's id
// buffer exactly.
#include <random>

#include "raster_support.h"

namespace rayclass::raster {
namespace {

using namespace testing_support;

scene::Camera MakeCamera(glm::vec3 eye, glm::vec3 at, uint32_t w, uint32_t h, float fov = 45) {
    scene::Camera c;
    c.position = eye;
    c.lookAt = at;
    c.width = w;
    c.height = h;
    c.fovYDegrees = fov;
    return c;
}

scene::Quadric Cylinder(glm::vec3 lo, glm::vec3 hi) {
    // x^2 + z^2 = r^2 around the box's vertical axis.
    scene::Quadric q;
    const glm::vec3 c = (lo + hi) * 0.5f;
    const float r = 0.5f * (hi.x - lo.x);
    q.c = {1, 0, 1, 0, 0, 0, -2 * c.x, 0, -2 * c.z, c.x * c.x + c.z * c.z - r * r};
    q.boxMin = lo;
    q.boxMax = hi;
    return q;
}

// Runs both paths with every hull and expects identical id buffers; returns the raster hits of
// the last hull.
// A hit is degenerate when its point lies far off its primitive: a ray inside the rounding noise
// of a triangle's plane, where the float determinant is noise and the result depends on the last
// bit of every operation (PoCL and llvmpipe then may disagree; no hull can cover it).
bool DegenerateHit(const scene::Scene& scene, const RcHit& h) {
    if (h.prim == RC_NO_HIT || h.prim >= scene.SphereBase()) return false;
    const render::CameraBasis basis(scene.camera);
    Bounds3f box;
    for (const auto& p : scene.triangles[h.prim].p) box.Grow(p);
    // A hit distance no point of the triangle has is far off it.
    const float slack = 0.01f * box.Diagonal();
    const float d = glm::length(box.Center() - glm::vec3(basis.position));
    return h.t > d + box.Diagonal() + slack || h.t < d - box.Diagonal() - slack;
}

std::vector<RcHit> ExpectSameIds(GlContext& gl, const scene::Scene& scene, size_t minHits = 1,
                                 size_t maxDegenerate = 0) {
    const std::vector<RcHit> kernel = KernelHits(scene);
    size_t kernelHits = 0;
    for (const auto& h : kernel) kernelHits += h.prim != RC_NO_HIT;
    EXPECT_GE(kernelHits, minHits) << "the scene should be visible";
    std::vector<RcHit> raster;
    for (Hull hull : {Hull::Sphere, Hull::Box, Hull::Billboard}) {
        RasterOptions options;
        options.hull = hull;
        RasterPass pass(gl, scene, options);
        raster = pass.Render(render::CameraBasis(scene.camera).ToDevice());
        const HitComparison cmp = CompareHits(raster, kernel);
        size_t degenerate = 0;
        for (size_t i : cmp.mismatchPixels) {
            if (DegenerateHit(scene, kernel[i]) || DegenerateHit(scene, raster[i])) ++degenerate;
        }
        std::printf("hull %s: %zu kernel hits, %zu id mismatches (%zu degenerate)\n",
                    HullName(hull), kernelHits, cmp.idMismatch, degenerate);
        EXPECT_LE(degenerate, maxDegenerate) << "hull " << HullName(hull);
        EXPECT_EQ(cmp.idMismatch, degenerate) << "hull " << HullName(hull) << ", " << kernelHits
                                              << " kernel hits, " << cmp.missVsHit
                                              << " hit vs miss";
        for (size_t i : cmp.mismatchPixels) {
            if (DegenerateHit(scene, kernel[i]) || DegenerateHit(scene, raster[i])) continue;
            ADD_FAILURE() << "pixel (" << i % scene.camera.width << ", " << i / scene.camera.width
                          << "): kernel " << kernel[i].prim << " t " << kernel[i].t << " uv "
                          << kernel[i].u << " " << kernel[i].v << ", raster " << raster[i].prim
                          << " t " << raster[i].t;
        }
    }
    return raster;
}

TEST(RasterCornerCases, EdgeOnTriangles) {
    RC_REQUIRE_GL();
    // Fans of triangles whose planes pass through (or within a hair of) the eye: each projects
    // to a line, yet float rays on either side may hit them.
    scene::Scene scene;
    scene.camera = MakeCamera({0, 0, 5}, {0, 0, 0}, 96, 72);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> off(-1e-4f, 1e-4f);
    for (int k = 0; k < 24; ++k) {
        const float a = float(k) * 3.14159265f / 24.0f;
        const glm::vec3 dir(std::cos(a), std::sin(a), 0);
        const glm::vec3 lift = glm::vec3(-dir.y, dir.x, 0) * off(rng);
        scene::Triangle t;
        // Plane spanned by dir and the view axis: contains the eye (up to `lift`).
        t.p = {dir * 0.2f + lift + glm::vec3(0, 0, 1), dir * 2.0f + lift + glm::vec3(0, 0, -2),
               dir * 2.5f + lift + glm::vec3(0, 0, 2)};
        scene.triangles.push_back(t);
    }
    // A floor seen exactly edge-on (plane y = 0 through the eye).
    scene::Triangle f;
    f.p = {glm::vec3(-4, 0, -4), glm::vec3(4, 0, -4), glm::vec3(0, 0, 3)};
    scene.triangles.push_back(f);
    // One pixel of 6,912 has a kernel "hit" 30 units along a ray that passes 2 units from the
    // triangle (|det| = 2^-25): it is covered, but llvmpipe's float rounding decides otherwise.
    ExpectSameIds(*gl, scene, 0, 2);
}

TEST(RasterCornerCases, TinySpheresUnderOnePixel) {
    RC_REQUIRE_GL();
    scene::Scene scene;
    scene.camera = MakeCamera({0, 0, 10}, {0, 0, 0}, 80, 60, 40);
    // Pixel footprint at distance 10: 2 * 10 * tan(20 deg) / 60 = 0.12; radii 0.005..0.05.
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> pos(-3, 3), rad(0.005f, 0.05f);
    for (int i = 0; i < 400; ++i) {
        scene::Sphere s;
        s.center = {pos(rng), pos(rng) * 0.75f, pos(rng)};
        s.radius = rad(rng);
        scene.spheres.push_back(s);
    }
    for (int i = 0; i < 40; ++i) {
        const glm::vec3 c(pos(rng), pos(rng) * 0.75f, pos(rng));
        const float r = rad(rng);
        scene.quadrics.push_back(Cylinder(c - r, c + r));
    }
    ExpectSameIds(*gl, scene, 20);
}

TEST(RasterCornerCases, ObjectsPartlyBehindTheCamera) {
    RC_REQUIRE_GL();
    scene::Scene scene;
    scene.camera = MakeCamera({0, 1, 0}, {0, 1, -1}, 96, 72, 60);
    // A floor reaching far behind the eye, a sphere around the eye (its inside is seen), a
    // sphere and a cylinder half behind the eye plane, a triangle with a vertex behind the eye.
    scene::Triangle a, b;
    a.p = {glm::vec3(-20, 0, -20), glm::vec3(20, 0, -20), glm::vec3(20, 0, 20)};
    b.p = {glm::vec3(-20, 0, -20), glm::vec3(20, 0, 20), glm::vec3(-20, 0, 20)};
    scene.triangles = {a, b};
    scene::Triangle c;
    c.p = {glm::vec3(-1, 1.5f, 3), glm::vec3(1, 1.2f, -4), glm::vec3(-2, 2.5f, -3)};
    scene.triangles.push_back(c);
    scene.spheres.push_back({{0, 1, 0}, 30});
    scene.spheres.push_back({{1.5f, 1, 0.2f}, 0.8f});
    scene.quadrics.push_back(Cylinder({-2.5f, 0, -0.5f}, {-1.5f, 2, 0.5f}));
    ExpectSameIds(*gl, scene, 96 * 72);
}

TEST(RasterCornerCases, ObjectsCrossingTheNearPlane) {
    RC_REQUIRE_GL();
    scene::Scene scene;
    scene.camera = MakeCamera({0, 0, 0}, {0, 0, -1}, 64, 48);
    // Scene extent about 10, so the pass's near distance is about 1e-3: these reach the eye plane.
    scene::Triangle t;
    t.p = {glm::vec3(-0.3f, -0.2f, -1e-5f), glm::vec3(0.5f, -0.1f, -3), glm::vec3(0.2f, 0.4f, 1)};
    scene.triangles.push_back(t);
    scene.spheres.push_back({{0.4f, 0.3f, -0.05f}, 0.06f});   // touches z = 0.01 of the eye
    scene.spheres.push_back({{-0.3f, 0.2f, -0.0004f}, 0.05f}); // straddles the eye plane
    scene.quadrics.push_back(Cylinder({-0.2f, -0.3f, -0.1f}, {0.0f, 0.0f, 0.1f}));
    scene.spheres.push_back({{0, 0, -10}, 3});
    ExpectSameIds(*gl, scene, 100);
}

// Two triangles of an axis-aligned rectangle in the plane `axis` = `at`, spanning lo..hi in the
// next two axes, cyclically (axis 1: z, x).
void AddRectangle(scene::Scene& scene, int axis, float at, glm::vec2 lo, glm::vec2 hi) {
    auto corner = [&](float u, float w) {
        glm::vec3 p;
        p[axis] = at;
        p[(axis + 1) % 3] = u;
        p[(axis + 2) % 3] = w;
        return p;
    };
    scene::Triangle a, b;
    a.p = {corner(lo.x, lo.y), corner(hi.x, lo.y), corner(hi.x, hi.y)};
    b.p = {corner(lo.x, lo.y), corner(hi.x, hi.y), corner(lo.x, hi.y)};
    scene.triangles.push_back(a);
    scene.triangles.push_back(b);
}

TEST(RasterCornerCases, WallsPassingBesideTheEyeAreClippedAtTheNearPlane) {
    RC_REQUIRE_GL();
    // Inside a corridor: floor, ceiling and side walls run from behind the eye to far ahead, so
    // every one of their triangles crosses the eye plane. Their hits all lie beyond the near
    // distance; only the part there is drawn, and the ids stay the kernel's.
    scene::Scene corridor;
    corridor.camera = MakeCamera({0.2f, 0.1f, 0}, {0.2f, 0.1f, -1}, 96, 72, 60);
    AddRectangle(corridor, 1, -1, {-20, -1}, {5, 1});  // floor: z, x
    AddRectangle(corridor, 1, 1, {-20, -1}, {5, 1});   // ceiling
    AddRectangle(corridor, 0, -1, {-1, -20}, {1, 5});  // walls: y, z
    AddRectangle(corridor, 0, 1, {-1, -20}, {1, 5});
    AddRectangle(corridor, 2, -20, {-1, -1}, {1, 1});  // the far end
    corridor.spheres.push_back({{0.3f, -0.5f, -6}, 0.4f});
    ExpectSameIds(*gl, corridor, 96 * 72);

    // A floor crossing the eye plane just below the eye, seen at grazing angles up to its far
    // edge; closer to the eye (within 1e-3 of its farthest vertex) it would cover the screen.
    scene::Scene grazing;
    grazing.camera = MakeCamera({0, 0, 0}, {0, 0, -1}, 96, 72, 60);
    AddRectangle(grazing, 1, -0.05f, {-20, -3}, {5, 3});  // z, x
    grazing.spheres.push_back({{0.5f, 0.3f, -4}, 0.5f});
    ExpectSameIds(*gl, grazing, 100, 2);

    // A floor below a narrow view, crossing the eye plane without coming into view, costs no
    // fragment; drawn over the whole screen, as a triangle crossing the eye plane once was, its
    // two triangles would cost two per pixel.
    scene::Scene floor;
    floor.camera = MakeCamera({0, 0, 0}, {0, 0, -1}, 64, 48, 20);
    AddRectangle(floor, 1, -1, {-2, -2}, {5, 2});  // z, x
    floor.spheres.push_back({{0, 0, -10}, 0.5f});
    RasterOptions options;
    options.countFragments = true;
    RasterPass pass(*gl, floor, options);
    RasterStats stats;
    const std::vector<RcHit> hits =
        pass.Render(render::CameraBasis(floor.camera).ToDevice(), &stats);
    EXPECT_EQ(CompareHits(hits, KernelHits(floor)).idMismatch, 0u);
    // The sphere's square hull: about (0.5 / 10 / tan 10 deg)^2 = 8 % of the screen, plus margin.
    EXPECT_LT(stats.fragments, 64u * 48u / 5u);
    EXPECT_GT(stats.fragments, 0u);
}

TEST(RasterCornerCases, MoreThan65536PrimitivesKeepTheirIds) {
    RC_REQUIRE_GL();
    // A 300 x 230 grid of tiny triangles (69,000) and spheres after them: ids above 2^16 must come
    // back whole (a 16-bit id buffer would wrap them onto the first triangles).
    scene::Scene scene;
    scene.camera = MakeCamera({0, 0, 12}, {0, 0, 0}, 64, 48, 40);
    const int nx = 300, ny = 230;
    for (int j = 0; j < ny; ++j) {
        for (int i = 0; i < nx; ++i) {
            const float x = -4.0f + 8.0f * (float(i) + 0.5f) / nx;
            const float y = -3.0f + 6.0f * (float(j) + 0.5f) / ny;
            const float s = 0.012f;
            scene::Triangle t;
            t.p = {glm::vec3(x - s, y - s, 0), glm::vec3(x + s, y - s, 0), glm::vec3(x, y + s, 0)};
            scene.triangles.push_back(t);
        }
    }
    for (int k = 0; k < 10; ++k) scene.spheres.push_back({{-3.0f + 0.6f * k, 0, 1}, 0.2f});
    ASSERT_GT(scene.PrimitiveCount(), 65536u);
    const std::vector<RcHit> kernel = KernelHits(scene);
    RasterPass pass(*gl, scene);
    const std::vector<RcHit> raster = pass.Render(render::CameraBasis(scene.camera).ToDevice());
    const HitComparison cmp = CompareHits(raster, kernel);
    EXPECT_EQ(cmp.idMismatch, 0u);
    size_t above = 0;
    for (const auto& h : raster) above += h.prim != RC_NO_HIT && h.prim >= 65536u;
    EXPECT_GT(above, 40u) << "ids above 2^16 should be visible";
}

}  // namespace
}  // namespace rayclass::raster
