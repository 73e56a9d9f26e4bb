// The project's tessellator: a patch as an n x n grid of quads over its parameters, each split
// into two triangles, with the vertices on the surface (rational evaluation in double, rounded to
// float) and vertex normals from the surface's derivatives (geometry::PatchNormal, collapsed
// edges included). Triangles that collapse to a line or a point (along the teapot's collapsed
// lid and bottom edges) are left out.
#pragma once

#include <cstdint>
#include <vector>

#include "rayclass/scene/scene.h"

namespace rayclass::scene {

// n >= 1 quads per parameter direction; material and object as the patch's.
std::vector<Triangle> TessellatePatch(const Patch& patch, uint32_t n);

}  // namespace rayclass::scene
