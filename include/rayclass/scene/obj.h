// Wavefront OBJ meshes and their MTL material libraries, parsed in-tree.
//
// Supported: v, vn, vt, f (forms v, v/vt, v//vn, v/vt/vn; positive and negative indices; polygons
// are fan-triangulated), o, g, usemtl, mtllib (several libraries, paths relative to the OBJ).
// MTL: newmtl, Kd, Ks, Ke, Ns, Ni, d, Tr (= 1 - d), illum. Other statements (s, l, p, map_*, Ka,
// ...) are ignored. '#' starts a comment anywhere on a line, a trailing '\' continues a line, CRLF
// line endings are accepted. Errors are SceneError naming the file and the 1-based physical line
// where the statement starts; docs/scene-format.md lists the messages.
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

// Marks an absent normal/texcoord index, or a triangle without material or group.
inline constexpr int32_t kObjNone = -1;

struct ObjTriangle {
    std::array<uint32_t, 3> position{};                           // 0-based into ObjMesh::positions
    std::array<int32_t, 3> normal{kObjNone, kObjNone, kObjNone};  // into normals, or kObjNone
    std::array<int32_t, 3> texcoord{kObjNone, kObjNone, kObjNone};  // into texcoords, or kObjNone
    int32_t material = kObjNone;  // into ObjMesh::materials; kObjNone before any usemtl
    int32_t group = kObjNone;     // into ObjMesh::groups; kObjNone before any o/g
};

struct ObjMesh {
    std::vector<glm::vec3> positions;
    std::vector<glm::vec3> normals;  // as written (not renormalised)
    std::vector<glm::vec2> texcoords;
    std::vector<ObjTriangle> triangles;
    std::vector<Material> materials;  // every material of every mtllib, in definition order
    std::vector<std::string> groups;  // names of o and g statements, in file order
};

// Reads `file` and the MTL libraries it names. Throws SceneError.
ObjMesh LoadObj(const std::filesystem::path& file);

// Parses OBJ text; `file` names it in errors and anchors relative mtllib paths. Text of 8 MiB
// or more is parsed in pieces of at least 4 MiB, at most one a core (`pieces` > 0 sets how
// many); the mesh and the first error are the same for any number of pieces.
ObjMesh ParseObj(std::string_view text, const std::filesystem::path& file, size_t pieces = 0);

// 1-based line of the `index`-th (0-based) statement `keyword` of OBJ/MTL `text`, 0 when there
// is none; for messages about parsed values (it re-reads the text).
int StatementLine(std::string_view text, std::string_view keyword, size_t index);

// Parses MTL text into materials mapped onto the Whitted model (see docs/scene-format.md).
std::vector<Material> ParseMtl(std::string_view text, const std::filesystem::path& file);

}  // namespace rayclass::scene
