#include "rayclass/scene/obj.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "scene/test_files.h"

namespace rayclass::scene {
namespace {

using testing::ErrorOf;
using testing::ScenesDir;
using testing::TempDir;

// Loads `text` as x.obj in a fresh directory; returns the error message, or "" when it loads.
std::string ObjError(std::string_view text) {
    TempDir dir;
    const auto file = dir.Write("x.obj", text);
    const std::string what = ErrorOf([&] { LoadObj(file); });
    const std::string prefix = file.string() + ":";
    return what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what;
}

const char* const kSquare =
    "v 0 0 0\n"
    "v 1 0 0\n"
    "v 1 1 0\n"
    "v 0 1 0\n";

TEST(ObjParse, ReadsVerticesNormalsAndTexcoords) {
    const ObjMesh m = ParseObj(
        "v 1 2 3\n"
        "v -1.5e2 +2 .25 1\n"
        "vn 0 0 1\n"
        "vt 0.5\n"
        "vt 0.25 0.75 0\n",
        "x.obj");
    ASSERT_EQ(m.positions.size(), 2u);
    EXPECT_EQ(m.positions[0], glm::vec3(1, 2, 3));
    EXPECT_EQ(m.positions[1], glm::vec3(-150, 2, 0.25f));
    ASSERT_EQ(m.normals.size(), 1u);
    EXPECT_EQ(m.normals[0], glm::vec3(0, 0, 1));
    ASSERT_EQ(m.texcoords.size(), 2u);
    EXPECT_EQ(m.texcoords[0], glm::vec2(0.5f, 0));
    EXPECT_EQ(m.texcoords[1], glm::vec2(0.25f, 0.75f));
    EXPECT_TRUE(m.triangles.empty());
}

TEST(ObjParse, FaceFormsGiveCornerIndices) {
    const ObjMesh m = ParseObj(std::string(kSquare) +
                                   "vt 0 0\nvt 1 0\nvt 1 1\n"
                                   "vn 0 0 1\nvn 0 1 0\nvn 1 0 0\n"
                                   "f 1 2 3\n"
                                   "f 1/1 2/2 3/3\n"
                                   "f 1//3 2//2 3//1\n"
                                   "f 4/3/2 3/2/1 2/1/3\n",
                               "x.obj");
    ASSERT_EQ(m.triangles.size(), 4u);
    const ObjTriangle& plain = m.triangles[0];
    EXPECT_EQ(plain.position, (std::array<uint32_t, 3>{0, 1, 2}));
    EXPECT_EQ(plain.normal, (std::array<int32_t, 3>{kObjNone, kObjNone, kObjNone}));
    EXPECT_EQ(plain.texcoord, (std::array<int32_t, 3>{kObjNone, kObjNone, kObjNone}));
    EXPECT_EQ(m.triangles[1].texcoord, (std::array<int32_t, 3>{0, 1, 2}));
    EXPECT_EQ(m.triangles[1].normal, (std::array<int32_t, 3>{kObjNone, kObjNone, kObjNone}));
    EXPECT_EQ(m.triangles[2].normal, (std::array<int32_t, 3>{2, 1, 0}));
    EXPECT_EQ(m.triangles[2].texcoord, (std::array<int32_t, 3>{kObjNone, kObjNone, kObjNone}));
    EXPECT_EQ(m.triangles[3].position, (std::array<uint32_t, 3>{3, 2, 1}));
    EXPECT_EQ(m.triangles[3].texcoord, (std::array<int32_t, 3>{2, 1, 0}));
    EXPECT_EQ(m.triangles[3].normal, (std::array<int32_t, 3>{1, 0, 2}));
    EXPECT_EQ(plain.material, kObjNone);
    EXPECT_EQ(plain.group, kObjNone);
}

TEST(ObjParse, NegativeIndicesCountBackFromTheLastDefined) {
    const ObjMesh m = ParseObj(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 0 1\nvt 0 0\n"
        "f -3/-1/-1 -2/-1/-1 -1/-1/-1\n"
        "v 5 5 5\n"
        "f -4 -3 -1\n",
        "x.obj");
    ASSERT_EQ(m.triangles.size(), 2u);
    EXPECT_EQ(m.triangles[0].position, (std::array<uint32_t, 3>{0, 1, 2}));
    EXPECT_EQ(m.triangles[0].normal, (std::array<int32_t, 3>{0, 0, 0}));
    EXPECT_EQ(m.triangles[0].texcoord, (std::array<int32_t, 3>{0, 0, 0}));
    EXPECT_EQ(m.triangles[1].position, (std::array<uint32_t, 3>{0, 1, 3}));
}

TEST(ObjParse, QuadsAndPolygonsAreFanTriangulated) {
    const ObjMesh m = ParseObj(std::string(kSquare) +
                                   "v 0.5 2 0\n"
                                   "f 1 2 3 4\n"
                                   "f 1 2 3 5 4\n",
                               "x.obj");
    ASSERT_EQ(m.triangles.size(), 5u);
    EXPECT_EQ(m.triangles[0].position, (std::array<uint32_t, 3>{0, 1, 2}));
    EXPECT_EQ(m.triangles[1].position, (std::array<uint32_t, 3>{0, 2, 3}));
    EXPECT_EQ(m.triangles[2].position, (std::array<uint32_t, 3>{0, 1, 2}));
    EXPECT_EQ(m.triangles[3].position, (std::array<uint32_t, 3>{0, 2, 4}));
    EXPECT_EQ(m.triangles[4].position, (std::array<uint32_t, 3>{0, 4, 3}));
}

TEST(ObjParse, ObjectsAndGroupsNameTheirTriangles) {
    const ObjMesh m = ParseObj(std::string(kSquare) +
                                   "f 1 2 3\n"
                                   "o box\n"
                                   "f 1 2 3\n"
                                   "g lid part\n"
                                   "f 1 2 3\n",
                               "x.obj");
    ASSERT_EQ(m.groups, (std::vector<std::string>{"box", "lid part"}));
    EXPECT_EQ(m.triangles[0].group, kObjNone);
    EXPECT_EQ(m.triangles[1].group, 0);
    EXPECT_EQ(m.triangles[2].group, 1);
}

TEST(ObjParse, CommentsBlanksContinuationsAndCrlf) {
    const ObjMesh m = ParseObj(
        "# header\r\n"
        "\r\n"
        "   \t\r\n"
        "   v 1 2 3 # trailing comment\r\n"
        "v 4 \\\r\n"
        "  5 \\\n"
        "  6\r\n"
        "# a comment ending in a backslash continues nothing \\\n"
        "v 7 8 9\n"
        "f 1 2 \\\n"
        "3",
        "x.obj");
    ASSERT_EQ(m.positions.size(), 3u);
    EXPECT_EQ(m.positions[0], glm::vec3(1, 2, 3));
    EXPECT_EQ(m.positions[1], glm::vec3(4, 5, 6));
    EXPECT_EQ(m.positions[2], glm::vec3(7, 8, 9));
    ASSERT_EQ(m.triangles.size(), 1u);
}

TEST(ObjParse, UnknownStatementsAreIgnored) {
    const ObjMesh m = ParseObj(std::string(kSquare) +
                                   "s 1\n"
                                   "l 1 2\n"
                                   "p 1\n"
                                   "vp 0.5\n"
                                   "map_Kd tex.png\n"
                                   "cstype bezier\n"
                                   "f 1 2 3\n",
                               "x.obj");
    EXPECT_EQ(m.positions.size(), 4u);
    EXPECT_EQ(m.triangles.size(), 1u);
}

TEST(ObjMaterials, MtllibAndUsemtlAssignMaterials) {
    TempDir dir;
    dir.Write("a.mtl", "newmtl red\nKd 1 0 0\nnewmtl green\nKd 0 1 0\n");
    dir.Write("sub/b.mtl", "newmtl blue\nKd 0 0 1\n");
    dir.Write("c.mtl", "newmtl grey\nKd 0.5\n");
    const auto file = dir.Write("x.obj", std::string(kSquare) +
                                             "usemtl grey\n"  // before its mtllib: still found
                                             "f 1 2 3\n"
                                             "mtllib a.mtl sub/b.mtl\n"
                                             "mtllib c.mtl\n"
                                             "usemtl blue\n"
                                             "f 1 2 3\n"
                                             "usemtl green\n"
                                             "f 1 2 3 4\n");
    const ObjMesh m = LoadObj(file);
    ASSERT_EQ(m.materials.size(), 4u);
    EXPECT_EQ(m.materials[0].name, "red");
    EXPECT_EQ(m.materials[2].name, "blue");
    EXPECT_EQ(m.materials[3].kd, glm::vec3(0.5f));
    ASSERT_EQ(m.triangles.size(), 4u);
    EXPECT_EQ(m.triangles[0].material, 3);
    EXPECT_EQ(m.triangles[1].material, 2);
    EXPECT_EQ(m.triangles[2].material, 1);
    EXPECT_EQ(m.triangles[3].material, 1);
}

TEST(ObjMaterials, MtlMapsOntoWhittedMaterials) {
    const std::vector<Material> m = ParseMtl(
        "# comment\n"
        "newmtl plastic\n"
        "  Ka 0.1 0.1 0.1\n"
        "  Kd 0.2 0.3 0.4\r\n"
        "  Ks 0.5 0.5 0.5\n"
        "  Ns 64\n"
        "  Ke 1 2 3\n"
        "  map_Kd plastic.png\n"
        "  illum 2\n"
        "newmtl mirror\nKs 0.9 0.8 0.7\nillum 3\n"
        "newmtl fresnel_mirror\nKs 0.9\nillum 5\n"
        "newmtl glass\nNi 1.33\nillum 4\n"
        "newmtl tinted\nd 0.25\n"
        "newmtl tr\nTr 0.75\n"
        "newmtl refract\nillum 7\n",
        "x.mtl");
    ASSERT_EQ(m.size(), 7u);
    EXPECT_EQ(m[0].name, "plastic");
    EXPECT_EQ(m[0].kd, glm::vec3(0.2f, 0.3f, 0.4f));
    EXPECT_EQ(m[0].ks, glm::vec3(0.5f));
    EXPECT_EQ(m[0].shininess, 64.0f);
    EXPECT_EQ(m[0].emission, glm::vec3(1, 2, 3));
    EXPECT_EQ(m[0].kr, glm::vec3(0));
    EXPECT_EQ(m[0].kt, glm::vec3(0));
    EXPECT_FALSE(m[0].fresnel);

    EXPECT_EQ(m[1].kr, glm::vec3(0.9f, 0.8f, 0.7f));
    EXPECT_FALSE(m[1].fresnel);
    EXPECT_EQ(m[2].kr, glm::vec3(0.9f));
    EXPECT_TRUE(m[2].fresnel);

    EXPECT_EQ(m[3].kt, glm::vec3(1));
    EXPECT_EQ(m[3].ior, 1.33f);
    EXPECT_TRUE(m[3].fresnel);
    EXPECT_EQ(m[4].kt, glm::vec3(0.75f));
    EXPECT_TRUE(m[4].fresnel);
    EXPECT_EQ(m[5].kt, glm::vec3(0.75f));  // Tr 0.75 = d 0.25
    EXPECT_EQ(m[6].kt, glm::vec3(1));
    EXPECT_TRUE(m[6].fresnel);
}

TEST(ObjErrors, FileProblems) {
    TempDir dir;
    const auto missing = dir.path() / "missing.obj";
    EXPECT_EQ(ErrorOf([&] { LoadObj(missing); }), missing.string() + ": missing file");
    std::filesystem::create_directories(dir.path() / "d.obj");
    EXPECT_EQ(ErrorOf([&] { LoadObj(dir.path() / "d.obj"); }),
              (dir.path() / "d.obj").string() + ": is a directory");
}

TEST(ObjErrors, UnreadableFile) {
    if (::geteuid() == 0) GTEST_SKIP() << "root reads files regardless of their mode";
    TempDir dir;
    const auto file = dir.Write("x.obj", "v 0 0 0\n");
    std::filesystem::permissions(file, std::filesystem::perms::none);
    EXPECT_EQ(ErrorOf([&] { LoadObj(file); }),
              file.string() + ": cannot read file (Permission denied)");
}

TEST(ObjErrors, BadNumbers) {
    EXPECT_EQ(ObjError("v 1 2 3\nv 1 abc 3\n"), "2: malformed number 'abc' in 'v' statement");
    EXPECT_EQ(ObjError("v 1 2 3x\n"), "1: malformed number '3x' in 'v' statement");
    EXPECT_EQ(ObjError("v 1 2 +-3\n"), "1: malformed number '+-3' in 'v' statement");
    EXPECT_EQ(ObjError("vn 0 nan 1\n"), "1: non-finite number 'nan' in 'vn' statement");
    EXPECT_EQ(ObjError("v -inf 0 1\n"), "1: non-finite number '-inf' in 'v' statement");
    EXPECT_EQ(ObjError("vt 1e39 0\n"), "1: number '1e39' out of range in 'vt' statement");
    EXPECT_EQ(ObjError("v 1 2\n"), "1: expected 3 to 6 numbers in 'v' statement, got 2");
    EXPECT_EQ(ObjError("vn 1 2 3 4\n"), "1: expected 3 numbers in 'vn' statement, got 4");
    EXPECT_EQ(ObjError("vt\n"), "1: expected 1 to 3 numbers in 'vt' statement, got 0");
}

TEST(ObjParse, TinyNumbersFlushToZero) {
    const ObjMesh m = ParseObj("v 1e-50 -1e-400 1e-40\n", "x.obj");
    EXPECT_EQ(m.positions[0].x, 0.0f);
    EXPECT_EQ(m.positions[0].y, 0.0f);
    EXPECT_NEAR(m.positions[0].z, 1e-40f, 1e-44f);
}

TEST(ObjErrors, IndicesOutOfRange) {
    const std::string eight = std::string(kSquare) + kSquare;
    EXPECT_EQ(ObjError(eight + "f 1 2 12\n"),
              "9: vertex index 12 out of range (8 vertices defined)");
    EXPECT_EQ(ObjError(eight + "f -9 1 2\n"),
              "9: vertex index -9 out of range (8 vertices defined)");
    EXPECT_EQ(ObjError("v 0 0 0\nf 1 1 2\n"), "2: vertex index 2 out of range (1 vertex defined)");
    EXPECT_EQ(ObjError(eight + "vn 0 0 1\nf 1//1 2//2 3//1\n"),
              "10: normal index 2 out of range (1 normal defined)");
    EXPECT_EQ(ObjError(eight + "vt 0 0\nvt 1 1\nf 1/1 2/-3 3/1\n"),
              "11: texcoord index -3 out of range (2 texcoords defined)");
    EXPECT_EQ(ObjError(eight + "f 1//1 2//1 3//1\n"),
              "9: normal index 1 out of range (0 normals defined)");
    EXPECT_EQ(ObjError(eight + "f 1 2 99999999999999999999\n"),
              "9: vertex index 99999999999999999999 out of range (8 vertices defined)");
    EXPECT_EQ(ObjError(eight + "f 1 0 2\n"), "9: index 0 is not allowed");
    EXPECT_EQ(ObjError(eight + "vt 0 0\nf 1/0 2/1 3/1\n"), "10: index 0 is not allowed");
}

TEST(ObjErrors, MalformedFaces) {
    const std::string four = kSquare;
    EXPECT_EQ(ObjError(four + "f 1 2\n"), "5: face with fewer than 3 vertices");
    EXPECT_EQ(ObjError(four + "f\n"), "5: face with fewer than 3 vertices");
    EXPECT_EQ(ObjError(four + "f 1 2 a\n"), "5: malformed face vertex 'a' in 'f' statement");
    EXPECT_EQ(ObjError(four + "f 1 2 3/\n"), "5: malformed face vertex '3/' in 'f' statement");
    EXPECT_EQ(ObjError(four + "f 1 2 3//\n"), "5: malformed face vertex '3//' in 'f' statement");
    EXPECT_EQ(ObjError(four + "f 1 2 /1\n"), "5: malformed face vertex '/1' in 'f' statement");
    EXPECT_EQ(ObjError(four + "f 1 2 1/1/1/1\n"),
              "5: malformed face vertex '1/1/1/1' in 'f' statement");
    EXPECT_EQ(ObjError(four + "f 1 2 +3\n"), "5: malformed face vertex '+3' in 'f' statement");
}

TEST(ObjErrors, LineNumbersArePhysicalWithCrlfAndContinuations) {
    EXPECT_EQ(ObjError("v 0 0 0\r\n\r\nv 1 \\\r\n 2 \\\r\n 3\r\nv x 0 0\r\n"),
              "6: malformed number 'x' in 'v' statement");
    EXPECT_EQ(ObjError("v 0 0 0\nv 1 \\\n 2 \\\n y\n"), "2: malformed number 'y' in 'v' statement");
}

TEST(ObjErrors, MaterialProblems) {
    EXPECT_EQ(ObjError(std::string(kSquare) + "usemtl\n"), "5: 'usemtl' needs a material name");
    EXPECT_EQ(ObjError(std::string(kSquare) + "mtllib\n"), "5: 'mtllib' needs a file name");
    EXPECT_EQ(ObjError(std::string(kSquare) + "usemtl a\nf 1 2 3\nusemtl foo\nf 1 2 3\n"),
              "5: unknown material 'a'");

    TempDir dir;
    dir.Write("m.mtl", "newmtl a\nKd 1 1 1\n");
    const auto obj = dir.Write("x.obj", "mtllib m.mtl\nusemtl a\nusemtl foo\n");
    EXPECT_EQ(ErrorOf([&] { LoadObj(obj); }), obj.string() + ":3: unknown material 'foo'");

    const auto noLib = dir.Write("y.obj", "# no library\nmtllib m.mtl gone.mtl\n");
    EXPECT_EQ(ErrorOf([&] { LoadObj(noLib); }), noLib.string() + ":2: material library '" +
                                                    (dir.path() / "gone.mtl").string() +
                                                    "': missing file");
}

TEST(ObjErrors, MtlProblemsNameTheMtlFile) {
    const auto mtlError = [](std::string_view text) {
        return ErrorOf([&] { ParseMtl(text, "m.mtl"); });
    };
    EXPECT_EQ(mtlError("Kd 1 1 1\n"), "m.mtl:1: 'Kd' statement before 'newmtl'");
    EXPECT_EQ(mtlError("newmtl\n"), "m.mtl:1: 'newmtl' needs a material name");
    EXPECT_EQ(mtlError("newmtl a\nKd 1 red 1\n"),
              "m.mtl:2: malformed number 'red' in 'Kd' statement");
    EXPECT_EQ(mtlError("newmtl a\nKd 1 1 1 1\n"),
              "m.mtl:2: expected 1 to 3 numbers in 'Kd' statement, got 4");
    EXPECT_EQ(mtlError("newmtl a\nKs 1 -1 1\n"),
              "m.mtl:2: number '1 -1 1' out of range in 'Ks' statement");
    EXPECT_EQ(mtlError("newmtl a\nd 1.5\n"), "m.mtl:2: number '1.5' out of range in 'd' statement");
    EXPECT_EQ(mtlError("newmtl a\nTr -0.5\n"),
              "m.mtl:2: number '-0.5' out of range in 'Tr' statement");
    EXPECT_EQ(mtlError("newmtl a\nNi 0\n"), "m.mtl:2: number '0' out of range in 'Ni' statement");
    EXPECT_EQ(mtlError("newmtl a\nNs -1\n"), "m.mtl:2: number '-1' out of range in 'Ns' statement");
    EXPECT_EQ(mtlError("newmtl a\nNs inf\n"), "m.mtl:2: non-finite number 'inf' in 'Ns' statement");
    EXPECT_EQ(mtlError("newmtl a\nillum two\n"),
              "m.mtl:2: malformed number 'two' in 'illum' statement");
    EXPECT_EQ(mtlError("newmtl a\nillum 11\n"),
              "m.mtl:2: number '11' out of range in 'illum' statement");

    TempDir dir;
    const auto mtl = dir.Write("m.mtl", "newmtl a\n\nKd x\n");
    const auto obj = dir.Write("x.obj", "mtllib m.mtl\n");
    EXPECT_EQ(ErrorOf([&] { LoadObj(obj); }),
              mtl.string() + ":3: malformed number 'x' in 'Kd' statement");
}

TEST(ObjThirdParty, CornellBoxCounts) {
    // Embree's copy names cornell_box.mtl without shipping it: load a copy beside our own.
    TempDir dir;
    const auto obj = dir.path() / "cornell_box.obj";
    std::filesystem::copy_file(ScenesDir() / "tests" / "cornell_box_embree.obj", obj);
    dir.Write("cornell_box.mtl",
              "newmtl white\nKd 0.73 0.73 0.73\n"
              "newmtl red\nKd 0.65 0.05 0.05\n"
              "newmtl green\nKd 0.12 0.45 0.15\n"
              "newmtl blue\nKd 0.1 0.1 0.7\n"
              "newmtl light\nKd 0.78\nKe 15 15 15\n");
    const ObjMesh m = LoadObj(obj);
    EXPECT_EQ(m.positions.size(), 76u);  // 19 quads, the front wall's face commented out
    EXPECT_EQ(m.triangles.size(), 36u);  // 18 quads, each split in two
    EXPECT_EQ(m.groups.size(), 9u);
    EXPECT_EQ(m.materials.size(), 5u);
    int lit = 0;
    for (const ObjTriangle& t : m.triangles) lit += m.materials[size_t(t.material)].name == "light";
    EXPECT_EQ(lit, 2);
    // The light quad "f -4 -3 -2 -1" after the floor's 12 vertices: vertices 12..15.
    EXPECT_EQ(m.triangles[6].position, (std::array<uint32_t, 3>{12, 13, 14}));
}

TEST(ObjThirdParty, BunnyCounts) {
    const ObjMesh m = LoadObj(ScenesDir() / "bench" / "bunny.obj");
    EXPECT_EQ(m.positions.size(), 37706u);
    EXPECT_EQ(m.triangles.size(), 75408u);
    EXPECT_TRUE(m.materials.empty());
}

}  // namespace
}  // namespace rayclass::scene
