// Bezier and NURBS surfaces as the scene holds them: rational bicubic Bezier patches (scene.h
// Patch), made from Bezier nets of degree 1..3 by degree elevation and from clamped NURBS by knot
// insertion, and split into the patch boxes the queries see.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <glm/glm.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "rayclass/scene/scene.h"

namespace rayclass::scene {

// A Bezier net of degrees (du, dv), 1..3 each: (du + 1) (dv + 1) homogeneous points, point
// (i, j) at p[i (dv + 1) + j], i along u.
struct BezierNet {
    int du = 3, dv = 3;
    std::vector<glm::dvec4> p;
};

// The net raised to degree 3 in u and v (the same surface).
Patch ToBicubic(const BezierNet& net);

// A rational NURBS surface: degrees 1..3, clamped knot vectors (each end repeated degree + 1
// times, non-decreasing, interior multiplicity at most the degree), homogeneous control points
// (w x, w y, w z, w) at p[i nv + j], i along u, with nu = knotsU.size() - du - 1 and nv alike.
struct Nurbs {
    int du = 3, dv = 3;
    std::vector<double> knotsU, knotsV;
    std::vector<glm::dvec4> p;
};

// What is wrong with a knot vector for `degree` and `points` control points, or empty.
std::string KnotProblem(const std::vector<double>& knots, int degree, size_t points);

// The NURBS surface as Bezier nets by knot insertion, one per non-empty knot span pair (the
// input must be valid: KnotProblem empty for both directions, weights positive).
std::vector<BezierNet> NurbsToBezier(const Nurbs& n);

// Reads a .bpt file's text: the patch count, then per patch a line "du dv" and (du + 1) (dv + 1)
// lines "x y z". Throws SceneError naming `file` and the line.
std::vector<BezierNet> ParseBpt(std::string_view text, const std::filesystem::path& file);

// How patches become boxes. Each patch is halved (at u = 1/2 or v = 1/2, whichever leaves the
// flatter halves) while its control net strays from the bilinear surface through its corners by
// more than `flatness` times its box's diagonal, into at most kMaxFlatnessBoxes boxes; with
// boxesPerPatch (1..kMaxPatchBoxes) every patch gets exactly that many boxes instead, the least
// flat halved first.
struct PatchSplit {
    float flatness = 0.1f;
    uint32_t boxesPerPatch = 0;
};
inline constexpr uint32_t kMaxFlatnessBoxes = 256;
inline constexpr uint32_t kMaxPatchBoxes = 4096;
// No box is halved across a parameter extent of kMinPatchExtent or less: around a singular
// point (where the net folds onto itself) halving leaves the flatness measure where it was, and
// without this floor the split spent its whole budget there, down to ranges double cannot halve.
inline constexpr double kMinPatchExtent = 0x1p-20;

// The flatness measure above: the net's largest distance from the bilinear corner surface over
// the diagonal of its control points' box (0 for a point).
double PatchDeviation(const std::array<glm::dvec4, 16>& p);

// Replaces scene.patchBoxes with the split of every patch.
void SplitPatches(Scene& scene, const PatchSplit& split);

// The box of a net's control points (as Euclidean points), in float, rounded outward.
Bounds3f ControlBounds(const std::array<glm::dvec4, 16>& p);

// The two halves of a bicubic patch at u = 1/2 (alongU) or v = 1/2, by de Casteljau.
std::array<std::array<glm::dvec4, 16>, 2> HalvePatch(const std::array<glm::dvec4, 16>& p,
                                                     bool alongU);

}  // namespace rayclass::scene
