#include "rayclass/accel/grid.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "rayclass/accel/triangle_box.h"

namespace rayclass::accel {

namespace {

// The cells [lo, hi] (inclusive) that the box b overlaps.
std::pair<glm::ivec3, glm::ivec3> CellRange(const Grid& g, const Bounds3d& b) {
    const glm::dvec3 lo(g.box.lo), size(g.cellSize);
    const glm::ivec3 last = glm::ivec3(g.resolution) - 1;
    const glm::ivec3 a =
        glm::clamp(glm::ivec3(glm::floor((b.lo - lo) / size)), glm::ivec3(0), last);
    const glm::ivec3 z =
        glm::clamp(glm::ivec3(glm::floor((b.hi - lo) / size)), glm::ivec3(0), last);
    return {a, z};
}

Bounds3d CellBox(const Grid& g, const glm::ivec3& c) {
    const glm::dvec3 lo(g.box.lo), size(g.cellSize);
    return {lo + glm::dvec3(c) * size, lo + glm::dvec3(c + 1) * size};
}

void FlagMacroCells(Grid& g, uint32_t macroSize) {
    g.macroSize = macroSize;
    g.macroResolution = (g.resolution + macroSize - 1u) / macroSize;
    const glm::uvec3 m = g.macroResolution;
    g.macroOccupied.assign(size_t(m.x) * m.y * m.z, 0);
    for (uint32_t z = 0; z < g.resolution.z; ++z) {
        for (uint32_t y = 0; y < g.resolution.y; ++y) {
            for (uint32_t x = 0; x < g.resolution.x; ++x) {
                const uint32_t c = x + g.resolution.x * (y + g.resolution.y * z);
                if (g.cellStart[c] == g.cellStart[c + 1]) {
                    ++g.emptyCells;
                    continue;
                }
                const glm::uvec3 mc = glm::uvec3(x, y, z) / macroSize;
                g.macroOccupied[mc.x + m.x * (mc.y + m.y * mc.z)] = 1;
            }
        }
    }
}

}  // namespace

glm::uvec3 GridResolution(const Bounds3f& box, uint32_t prims, const GridParams& params) {
    const glm::dvec3 size = glm::max(glm::dvec3(box.Size()), glm::dvec3(1e-30));
    const double volume = size.x * size.y * size.z;
    const double perUnit = std::cbrt(double(params.density) * std::max(1u, prims) / volume);
    glm::uvec3 res;
    for (int a = 0; a < 3; ++a) {
        res[a] = uint32_t(std::clamp(std::round(size[a] * perUnit), 1.0,
                                     double(std::max(1u, params.maxResolution))));
    }
    return res;
}

Grid BuildGrid(const scene::Scene& scene, const GridParams& params) {
    Grid g;
    const uint32_t n = scene.PrimitiveCount();
    Bounds3f box = scene.Bounds();
    if (box.Empty()) box = {glm::vec3(0.0f), glm::vec3(1.0f)};
    // Room for the padding, and no flat axis: a plane's cells still have a thickness.
    const float margin = 1e-4f * std::max(box.Diagonal(), 1e-20f);
    g.box = {box.lo - glm::vec3(margin), box.hi + glm::vec3(margin)};
    g.resolution = GridResolution(g.box, n, params);
    if (uint64_t(g.resolution.x) * g.resolution.y * g.resolution.z >= (1ull << 31)) {
        throw std::runtime_error("grid: too many cells");
    }
    g.cellSize = (g.box.hi - g.box.lo) / glm::vec3(g.resolution);
    g.pad = 1e-3f * std::min({g.cellSize.x, g.cellSize.y, g.cellSize.z});
    // (cell, primitive) pairs in primitive order, then sorted by cell keeping that order.
    std::vector<std::pair<uint32_t, uint32_t>> refs;
    std::vector<uint32_t> count(g.Cells() + 1, 0);
    for (uint32_t id = 0; id < n; ++id) {
        const Bounds3f pb = scene.PrimitiveBounds(id);
        const Bounds3d b = Padded({glm::dvec3(pb.lo), glm::dvec3(pb.hi)}, g.pad);
        const auto [lo, hi] = CellRange(g, b);
        const bool triangle = id < scene.triangles.size();
        const Triangle3d tri = triangle ? TriangleOf(scene, id) : Triangle3d{};
        for (int z = lo.z; z <= hi.z; ++z) {
            for (int y = lo.y; y <= hi.y; ++y) {
                for (int x = lo.x; x <= hi.x; ++x) {
                    if (triangle && !TriangleOverlapsBox(tri, Padded(CellBox(g, {x, y, z}), g.pad)))
                        continue;
                    const uint32_t c = x + g.resolution.x * (y + g.resolution.y * z);
                    refs.emplace_back(c, id);
                    ++count[c + 1];
                }
            }
        }
    }
    for (size_t c = 1; c < count.size(); ++c) count[c] += count[c - 1];
    g.cellStart = count;
    g.primIndex.resize(refs.size());
    for (const auto& [c, id] : refs) g.primIndex[count[c]++] = id;
    FlagMacroCells(g, std::max(1u, params.macroSize));
    return g;
}

}  // namespace rayclass::accel
