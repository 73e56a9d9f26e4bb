// Bezier and NURBS objects: what they load into (checked against surfaces known in closed form)
// and the exact message of every bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "rayclass/scene/loader.h"
#include "rayclass/scene/patch.h"
#include "scene/test_files.h"

namespace rayclass::scene {
namespace {

using testing::ErrorOf;
using testing::ScenesDir;
using testing::TempDir;

// The point at (u, v) of a bicubic patch, by de Casteljau halving's definition: the Bernstein sum.
glm::dvec3 Evaluate(const Patch& p, double u, double v) {
    auto b = [](int i, double s) {
        const double c[4] = {1, 3, 3, 1};
        return c[i] * std::pow(s, i) * std::pow(1 - s, 3 - i);
    };
    glm::dvec4 sum(0.0);
    for (int i = 0; i < 4; ++i) {
        for (int j = 0; j < 4; ++j) sum += b(i, u) * b(j, v) * p.p[size_t(i * 4 + j)];
    }
    return glm::dvec3(sum) / sum.w;
}

std::string Error(const TempDir& dir, std::string_view json) {
    const auto file = dir.Write("s.json", json);
    const std::string what = ErrorOf([&] { LoadScene(file); });
    const std::string prefix = file.string() + ":";
    return what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what;
}

std::string ObjectError(std::string_view object) {
    TempDir dir;
    return Error(dir, R"({"objects": [)" + std::string(object) + "]}");
}

std::string BptError(std::string_view bpt) {
    TempDir dir;
    const auto file = dir.Write("p.bpt", bpt);
    dir.Write("s.json", R"({"objects": [{"type": "bezier", "file": "p.bpt"}]})");
    const std::string what = ErrorOf([&] { LoadScene(dir.path() / "s.json"); });
    const std::string prefix = file.string() + ":";
    return what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what;
}

// A bilinear patch given at degree 1 in u and 2 in v is raised to bicubic without moving.
TEST(PatchInput, InlineLowDegreeIsRaisedExactly) {
    TempDir dir;
    const auto file = dir.Write("s.json", R"({"objects": [{"type": "bezier", "degree": [1, 2],
        "patches": [[[0, 0, 0], [1, 0, 2], [2, 0, 0], [0, 1, 0], [1, 1, 2], [2, 1, 0]]],
        "transform": {"translate": [0, 0, 5]}}]})");
    const Scene s = LoadScene(file);
    ASSERT_EQ(s.patches.size(), 1u);
    for (double u : {0.0, 0.3, 1.0}) {
        for (double v : {0.0, 0.25, 0.5, 1.0}) {
            // u runs along y (degree 1), v along the parabola x = 2 v, z = 4 v (1 - v).
            const glm::dvec3 p = Evaluate(s.patches[0], u, v);
            EXPECT_NEAR(p.x, 2 * v, 1e-12);
            EXPECT_NEAR(p.y, u, 1e-12);
            EXPECT_NEAR(p.z, 5 + 4 * v * (1 - v), 1e-12);
        }
    }
    EXPECT_GE(s.patchBoxes.size(), 1u);
}

// A quarter circle as a rational quadratic (weights 1, 1/sqrt 2, 1) with an interior knot: knot
// insertion gives two Bezier patches, every point of which lies on the cylinder x^2 + z^2 = 1.
TEST(PatchInput, NurbsByKnotInsertionStaysOnTheCircle) {
    TempDir dir;
    const double h = std::sqrt(0.5);
    const std::string w = std::to_string(h);
    // Control points of a half circle (two quarter arcs), degree 2 in u, 1 in v.
    const auto file = dir.Write("s.json", R"({"objects": [{"type": "nurbs", "degree": [2, 1],
        "knots": [[0, 0, 0, 0.5, 0.5, 1, 1, 1], [0, 0, 1, 1]],
        "points": [[1, 0, 0, 1], [1, 1, 0, 1], [1, 0, 1, )" +
                                              w + R"(], [1, 1, 1, )" + w + R"(],
                   [0, 0, 1, 1], [0, 1, 1, 1], [-1, 0, 1, )" +
                                              w + R"(], [-1, 1, 1, )" + w +
                                              R"(], [-1, 0, 0, 1], [-1, 1, 0, 1]]}]})");
    const Scene s = LoadScene(file);
    ASSERT_EQ(s.patches.size(), 2u);
    for (const Patch& p : s.patches) {
        for (double u = 0; u <= 1.0; u += 0.125) {
            for (double v : {0.0, 0.5, 1.0}) {
                const glm::dvec3 q = Evaluate(p, u, v);
                // The weight 1/sqrt 2 is written with six digits and read as a float.
                EXPECT_NEAR(q.x * q.x + q.z * q.z, 1.0, 5e-7);
                EXPECT_NEAR(q.y, v, 1e-12);
            }
        }
    }
    // The halves meet at the top of the arc.
    EXPECT_NEAR(Evaluate(s.patches[0], 1, 0).z, 1.0, 1e-12);
    EXPECT_NEAR(Evaluate(s.patches[1], 0, 0).x, 0.0, 1e-12);
}

TEST(PatchInput, TeapotFileLoads) {
    const Scene s = LoadScene(ScenesDir() / "teapot.json");
    EXPECT_EQ(s.patches.size(), 33u);  // 32 of the teapot, one of the floor
    EXPECT_GT(s.patchBoxes.size(), s.patches.size());
    EXPECT_EQ(s.PrimitiveCount(), s.spheres.size() + s.patchBoxes.size());
}

TEST(PatchInput, BoxesTileEachPatchAndHoldItsNet) {
    Scene s = LoadScene(ScenesDir() / "teapot.json");
    for (uint32_t n : {1u, 5u, 16u}) {
        SplitPatches(s, {0.2f, n});
        ASSERT_EQ(s.patchBoxes.size(), n * s.patches.size());
        std::vector<double> area(s.patches.size(), 0.0);
        for (const PatchBox& b : s.patchBoxes) {
            area[b.patch] += (b.u[1] - b.u[0]) * (b.v[1] - b.v[0]);
            for (double u : {0.0, 0.5, 1.0}) {
                for (double v : {0.0, 0.5, 1.0}) {
                    const glm::dvec3 q =
                        Evaluate(s.patches[b.patch], b.u[0] + u * (b.u[1] - b.u[0]),
                                 b.v[0] + v * (b.v[1] - b.v[0]));
                    Patch own;
                    own.p = b.p;
                    EXPECT_LT(glm::length(q - Evaluate(own, u, v)), 1e-9);
                    // The box holds the surface of its own net (convex hull).
                    EXPECT_TRUE(b.bounds.Contains(glm::vec3(Evaluate(own, u, v))));
                }
            }
        }
        for (double a : area) EXPECT_DOUBLE_EQ(a, 1.0);
    }
}

// The .bpt files fuzz_bpt found (tests/fuzz/regressions/bpt: nets folded onto a point, where
// halving leaves the flatness measure as it was): the split spent its budget at the fold, down to
// parameter ranges that double cannot halve. Each patch's boxes must tile its parameter square
// exactly, none narrower than kMinPatchExtent, and hold the patch's corners.
TEST(PatchInput, FoldedNetsFromTheFuzzerSplitExactly) {
    const std::filesystem::path dir = ScenesDir() / ".." / "tests" / "fuzz" / "regressions" / "bpt";
    size_t files = 0;
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
        ++files;
        TempDir temp;
        const Scene s = LoadScene(
            temp.Write("s.json", R"({"objects": [{"type": "bezier", "file": ")" +
                                     std::filesystem::absolute(entry.path()).string() + R"("}]})"));
        std::vector<double> area(s.patches.size(), 0.0);
        std::vector<int> corners(s.patches.size(), 0);
        for (const PatchBox& b : s.patchBoxes) {
            EXPECT_GE(b.u[1] - b.u[0], kMinPatchExtent) << entry.path();
            EXPECT_GE(b.v[1] - b.v[0], kMinPatchExtent) << entry.path();
            area[b.patch] += (b.u[1] - b.u[0]) * (b.v[1] - b.v[0]);
            for (int c = 0; c < 4; ++c) {
                const double u = c / 2, v = c % 2;
                if (b.bounds.Contains(glm::vec3(Evaluate(s.patches[b.patch], u, v)))) {
                    corners[b.patch] |= 1 << c;
                }
            }
        }
        for (size_t k = 0; k < s.patches.size(); ++k) {
            EXPECT_EQ(area[k], 1.0) << entry.path() << " patch " << k;
            EXPECT_EQ(corners[k], 15) << entry.path() << " patch " << k;
        }
    }
    EXPECT_EQ(files, 3u);
}

TEST(PatchInput, FlatnessParameterSetsTheSplit) {
    TempDir dir;
    std::filesystem::copy_file(ScenesDir() / "teapot.bpt", dir.path() / "teapot.bpt");
    auto boxes = [&](const char* flatness) {
        return LoadScene(dir.Write("s.json", std::string(R"({"patch_flatness": )") + flatness +
                                                 R"(, "objects": [{"type": "bezier",
            "file": "teapot.bpt"}]})"))
            .patchBoxes.size();
    };
    EXPECT_LT(boxes("0.5"), boxes("0.2"));
    EXPECT_LT(boxes("0.2"), boxes("0.1"));
}

TEST(PatchInput, BadBezierObjects) {
    EXPECT_EQ(ObjectError(R"({"type": "bezier"})"),
              "1: object 1: a bezier object needs either 'file' or 'patches'");
    EXPECT_EQ(ObjectError(R"({"type": "bezier", "patches": [[[0, 0, 0]]]})"),
              "1: object 1: patch 1 must be an array of 16 points for degrees 3 and 3");
    EXPECT_EQ(ObjectError(R"({"type": "bezier", "degree": [4, 1], "patches": []})"),
              "1: object 1: 'degree' must be two integers 1..3 (in u and v)");
    EXPECT_EQ(ObjectError(R"({"type": "bezier", "degree": [1, 1],
                              "patches": [[[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1e999, 0]]]})"),
              "2: number overflow parsing '1e999'");
    EXPECT_EQ(ObjectError(R"({"type": "bezier", "degree": [1, 1],
                              "patches": [[[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, "y", 0]]]})"),
              "2: object 1: patch 1: a point must be an array of 3 finite numbers");
    EXPECT_EQ(ObjectError(R"({"type": "bezier", "file": "missing.bpt"})").substr(0, 31),
              "1: object 1: patches '/tmp/rayc");
    EXPECT_EQ(ObjectError(R"({"type": "bezier", "degree": [1, 1],
        "patches": [[[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]],
        "transform": {"scale": 1e10, "translate": [1e12, 0, 0]}})"),
              "3: object 1: a control point is out of range after the transform (magnitude above "
              "1e+12)");
}

TEST(PatchInput, BadNurbs) {
    const std::string good = R"("degree": [1, 1], "knots": [[0, 0, 1, 1], [0, 0, 1, 1]])";
    const std::string points =
        R"("points": [[0, 0, 0, 1], [1, 0, 0, 1], [0, 1, 0, 1], [1, 1, 0, 1]])";
    auto nurbs = [](const std::string& body) {
        return ObjectError(R"({"type": "nurbs", )" + body + "}");
    };
    EXPECT_EQ(nurbs(good + ", " + points), "no SceneError");
    EXPECT_EQ(
        nurbs(
            R"("degree": [1, 1], "knots": [[0, 0, 1, 1], [0, 0, 1, 1]], "points": [[0, 0, 0, 1]])"),
        "1: object 1: 'points' must hold 2 x 2 = 4 points for these knots and degrees, not 1");
    EXPECT_EQ(
        nurbs(R"("degree": [1, 1], "knots": [[0, 0, 0.5, 1], [0, 0, 1, 1]], )" + points),
        "1: object 1: the knots in u must be clamped (each end repeated degree + 1 = 2 times)");
    EXPECT_EQ(nurbs(R"("degree": [1, 1], "knots": [[0, 0, 1, 1], [0, 1, 0, 1]], )" + points),
              "1: object 1: the knots in v must be non-decreasing (knot 3 is below knot 2)");
    // One knot too many for the points: the points are counted from the knots and degrees.
    EXPECT_EQ(
        nurbs(R"("degree": [1, 1], "knots": [[0, 0, 1, 1, 1], [0, 0, 1, 1]], )" + points),
        "1: object 1: 'points' must hold 3 x 2 = 6 points for these knots and degrees, not 4");
    EXPECT_EQ(nurbs(R"("degree": [1, 1], "knots": [[0, 0], [0, 0, 1, 1]], )" + points),
              "1: object 1: the knots in u must allow at least 2 control points for degree 1");
    // JSON has no NaN or infinity; a number too large for a double is the parser's error.
    EXPECT_EQ(nurbs(R"("degree": [1, 1], "knots": [[0, 0, 1e999, 1], [0, 0, 1, 1]], )" + points),
              "1: number overflow parsing '1e999'");
    EXPECT_EQ(nurbs(R"("degree": [1, 1], "knots": [[1, 1, 1, 1], [0, 0, 1, 1]], )" + points),
              "1: object 1: the knots in u must span a non-empty interval");
    EXPECT_EQ(
        nurbs(good + R"(, "points": [[0, 0, 0, 1], [1, 0, 0, 0], [0, 1, 0, 1], [1, 1, 0, 1]])"),
        "1: object 1: point 2: the weight w must be positive");
    EXPECT_EQ(
        nurbs(good + R"(, "points": [[0, 0, 0, 1], [1, 0, 0, -2], [0, 1, 0, 1], [1, 1, 0, 1]])"),
        "1: object 1: point 2: the weight w must be positive");
    EXPECT_EQ(nurbs(good + R"(, "points": [[0, 0, 0], [1, 0, 0, 1], [0, 1, 0, 1], [1, 1, 0, 1]])"),
              "1: object 1: point 1 must be an array of 4 finite numbers [x, y, z, w]");
    EXPECT_EQ(nurbs(R"("degree": [2, 1], "knots": [[0, 0, 0, 0.5, 0.5, 0.5, 1, 1, 1], [0, 0, 1, 1]],
                       "points": [])"),
              "1: object 1: the knots in u must not repeat interior knot 0.5 more often than the "
              "degree (2)");
}

TEST(PatchInput, BadBptFiles) {
    const std::string point = "0 0 0\n";
    std::string points16;
    for (int i = 0; i < 16; ++i) points16 += point;
    EXPECT_EQ(BptError(""), " empty file (expected the patch count)");  // no line: "FILE: ..."
    EXPECT_EQ(BptError("two\n"), "1: the first line must be the patch count, a positive integer");
    EXPECT_EQ(BptError("1\n3 4\n" + points16),
              "2: patch 1: the degree line must be two integers 1..3 (degrees in u and v)");
    EXPECT_EQ(BptError("1\n3\n" + points16),
              "2: patch 1: the degree line must be two integers 1..3 (degrees in u and v)");
    EXPECT_EQ(BptError("1\n3 3\n0 0 0\n0 0 0\n"), "4: truncated: patch 1 has 2 of its 16 points");
    EXPECT_EQ(BptError("2\n3 3\n" + points16), "18: truncated: patch 2 of 2 is missing");
    EXPECT_EQ(BptError("1\n1 1\n0 0 0\n0 0 nan\n0 0 0\n0 0 0\n"),
              "4: patch 1: non-finite coordinate 'nan'");
    EXPECT_EQ(BptError("1\n1 1\n0 0 0\n0 0 inf\n0 0 0\n0 0 0\n"),
              "4: patch 1: non-finite coordinate 'inf'");
    EXPECT_EQ(BptError("1\n1 1\n0 0 0\n0 0\n0 0 0\n0 0 0\n"),
              "4: patch 1: a point must be three finite numbers of magnitude at most 1e12 (got "
              "'0 0')");
    EXPECT_EQ(BptError("1\n1 1\n0 0 0\n0 0 0 0\n0 0 0\n0 0 0\n"),
              "4: patch 1: a point line holds three numbers only");
    EXPECT_EQ(BptError("1\n1 1\n0 0 0\n0 0 0\n0 0 0\n0 0 0\n1 1\n"),
              "7: more data after the 1 patches the first line counts");
}

}  // namespace
}  // namespace rayclass::scene
