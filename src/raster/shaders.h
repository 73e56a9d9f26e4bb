// GLSL sources of the raster pass, embedded so the binary runs from any directory.
#pragma once

#include <string>

namespace rayclass::raster::shaders {

// kind: 0 triangles, 1 spheres, 2 quadrics, 3 patch boxes; hull: 0 sphere, 1 box, 2 billboard
// (ignored for triangles); count: atomic fragment counters; slabs: skip fragments behind the
// previous slabs.
std::string Vertex(int kind, bool slabs);
std::string Geometry(int kind, int hull);
std::string Fragment(int kind, bool count, bool slabs);

// The patch boxes' Bounds and Intersect (patch_shaders.cpp).
const char* PatchBounds();
const char* PatchTest();

}  // namespace rayclass::raster::shaders
