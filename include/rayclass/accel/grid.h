// A uniform grid over the scene's primitives (--accel grid), after the GPU voxelization paper:
// its resolution from the density rule (about `density` cells per primitive, cubic cells where
// the box allows), filled by conservative voxelization: a triangle enters every cell it
// overlaps by the separating-axis test (triangle_box.h), a sphere or a quadric every cell its
// box overlaps. cl/grid.cl walks it with a 3D-DDA (Amanatides & Woo 1987).
//
// Robustness: each cell is tested grown by `pad` on every side, so a primitive lies in every
// cell that comes within `pad` of it, more than the walk's rounding can move a ray.
//
// Macro cells of macroSize^3 cells each (fewer at the far faces) flag whether any of their cells
// holds a primitive, so that a packet's walk passes over empty space a macro cell at a time.
#pragma once

#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "rayclass/core/bounds.h"
#include "rayclass/scene/scene.h"

namespace rayclass::accel {

struct GridParams {
    float density = 4.0f;          // cells per primitive (lambda)
    uint32_t maxResolution = 512;  // cells along an axis, at most
    uint32_t macroSize = 4;        // cells along each axis of a macro cell
};

struct Grid {
    Bounds3f box;              // the scene box, padded
    glm::uvec3 resolution{1};  // cells along each axis
    glm::vec3 cellSize{1.0f};  // (box.hi - box.lo) / resolution
    float pad = 0;             // see above
    // Cell (x, y, z) is c = x + res.x (y + res.y z); its primitives' global ids, ascending, are
    // primIndex[cellStart[c], cellStart[c + 1]).
    std::vector<uint32_t> cellStart;
    std::vector<uint32_t> primIndex;
    uint32_t emptyCells = 0;
    uint32_t macroSize = 1;
    glm::uvec3 macroResolution{1};  // (resolution + macroSize - 1) / macroSize
    // Macro cell (x, y, z) at x + macroResolution.x (y + macroResolution.y z): 1 where one of its
    // cells holds a primitive, else 0.
    std::vector<uint8_t> macroOccupied;

    uint32_t Cells() const { return resolution.x * resolution.y * resolution.z; }
    size_t Bytes() const {
        return (cellStart.size() + primIndex.size()) * sizeof(uint32_t) + macroOccupied.size();
    }
};

// The resolution the density rule gives a box of `prims` primitives.
glm::uvec3 GridResolution(const Bounds3f& box, uint32_t prims, const GridParams& params = {});

// Builds over every primitive of the scene (global ids).
Grid BuildGrid(const scene::Scene& scene, const GridParams& params = {});

}  // namespace rayclass::accel
