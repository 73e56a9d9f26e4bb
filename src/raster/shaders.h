// GLSL sources of the raster pass, embedded so the binary runs from any directory.
#pragma once

#include <string>

namespace rayclass::raster::shaders {

// kind: 0 triangles, 1 spheres, 2 quadrics; hull: 0 sphere, 1 box, 2 billboard (ignored for
// triangles); count: atomic fragment counters; slabs: skip fragments behind the previous slabs.
std::string Vertex(int kind, bool slabs);
std::string Geometry(int kind, int hull);
std::string Fragment(int kind, bool count, bool slabs);

}  // namespace rayclass::raster::shaders
