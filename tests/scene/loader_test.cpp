#include "rayclass/scene/loader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "scene/test_files.h"

namespace rayclass::scene {
namespace {

using testing::ErrorOf;
using testing::ScenesDir;
using testing::TempDir;

void ExpectNear(const glm::vec3& a, const glm::vec3& b) {
    EXPECT_NEAR(a.x, b.x, 1e-5f);
    EXPECT_NEAR(a.y, b.y, 1e-5f);
    EXPECT_NEAR(a.z, b.z, 1e-5f);
}

// Loads `json` as s.json (beside `dir`'s other files); returns the error without the file name.
std::string JsonError(const TempDir& dir, std::string_view json) {
    const auto file = dir.Write("s.json", json);
    const std::string what = ErrorOf([&] { LoadScene(file); });
    const std::string prefix = file.string() + ":";
    return what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what;
}

std::string JsonError(std::string_view json) { return JsonError(TempDir(), json); }

// A scene with one object `object` (a JSON object's text) and a material "white".
std::string WithObject(std::string_view object) {
    return R"({"materials": {"white": {}}, "objects": [)" + std::string(object) + "]}";
}

const char* const kTriangleObj =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
    "vn 0 0 1\n"
    "f 1//1 2//1 3//1\n";

TEST(SceneFile, LoadsEveryObjectType) {
    TempDir dir;
    dir.Write("tri.obj", kTriangleObj);
    const auto file = dir.Write("s.json", R"({
  "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_y": 40,
             "width": 320, "height": 240},
  "ambient": [0.1, 0.1, 0.1], "background": [0, 0, 0.2],
  "materials": {
    "white": {"kd": [0.8, 0.8, 0.8], "ks": [0.2, 0.2, 0.2], "shininess": 16},
    "mirror": {"kd": [0, 0, 0], "kr": 0.9},
    "glass": {"kt": [1, 0.9, 0.8], "ior": 1.33, "fresnel": true, "emission": [0.5, 0, 0]}
  },
  "lights": [{"position": [1, 2, 3], "intensity": 5},
             {"position": [0, 4, 0], "intensity": [1, 2, 3]},
             {"position": [0, 0, 0]}],
  "objects": [
    {"type": "mesh", "file": "tri.obj"},
    {"type": "sphere", "center": [0, 1, 0], "radius": 0.5, "material": "mirror"},
    {"type": "quadric", "coefficients": [1, 1, 0, 0, 0, 0, 0, 0, 0, -1],
     "box_min": [-1, -1, 0], "box_max": [1, 1, 2], "material": "glass", "name": "tube"},
    {"type": "sphere", "center": [2, 0, 0], "radius": 1, "name": "ball"}
  ]
})");
    const Scene s = LoadScene(file);
    EXPECT_EQ(s.camera.position, glm::vec3(0, 0, 5));
    EXPECT_EQ(s.camera.fovYDegrees, 40.0f);
    EXPECT_EQ(s.camera.width, 320u);
    EXPECT_EQ(s.camera.height, 240u);
    EXPECT_EQ(s.ambient, glm::vec3(0.1f));
    EXPECT_EQ(s.background, glm::vec3(0, 0, 0.2f));

    ASSERT_EQ(s.materials.size(), 4u);
    EXPECT_EQ(s.materials[0].name, "default");
    EXPECT_EQ(s.materials[1].name, "white");
    EXPECT_EQ(s.materials[1].shininess, 16.0f);
    EXPECT_EQ(s.materials[2].kr, glm::vec3(0.9f));
    EXPECT_EQ(s.materials[3].kt, glm::vec3(1, 0.9f, 0.8f));
    EXPECT_EQ(s.materials[3].ior, 1.33f);
    EXPECT_TRUE(s.materials[3].fresnel);
    EXPECT_EQ(s.materials[3].emission, glm::vec3(0.5f, 0, 0));

    ASSERT_EQ(s.lights.size(), 3u);
    EXPECT_EQ(s.lights[0].intensity, glm::vec3(5));
    EXPECT_EQ(s.lights[1].intensity, glm::vec3(1, 2, 3));
    EXPECT_EQ(s.lights[2].intensity, glm::vec3(1));

    ASSERT_EQ(s.objects.size(), 4u);
    EXPECT_EQ(s.objects[0].name, "tri.obj");
    EXPECT_EQ(s.objects[1].name, "sphere 2");
    EXPECT_EQ(s.objects[2].name, "tube");
    EXPECT_EQ(s.objects[3].name, "ball");

    ASSERT_EQ(s.triangles.size(), 1u);
    EXPECT_EQ(s.triangles[0].object, 0u);
    EXPECT_EQ(s.triangles[0].material, 0u);
    EXPECT_TRUE(s.triangles[0].hasNormals);
    ASSERT_EQ(s.spheres.size(), 2u);
    EXPECT_EQ(s.spheres[0].object, 1u);
    EXPECT_EQ(s.spheres[0].material, 2u);
    EXPECT_EQ(s.spheres[0].radius, 0.5f);
    EXPECT_EQ(s.spheres[1].object, 3u);
    EXPECT_EQ(s.spheres[1].material, 0u);
    ASSERT_EQ(s.quadrics.size(), 1u);
    EXPECT_EQ(s.quadrics[0].object, 2u);
    EXPECT_EQ(s.quadrics[0].material, 3u);
    EXPECT_EQ(s.quadrics[0].c[9], -1.0f);
    EXPECT_EQ(s.quadrics[0].boxMax, glm::vec3(1, 1, 2));
}

TEST(SceneFile, TransformScalesThenRotatesThenTranslates) {
    TempDir dir;
    dir.Write("tri.obj", kTriangleObj);
    const auto file = dir.Write("s.json", R"({"objects": [{"type": "mesh", "file": "tri.obj",
        "transform": {"translate": [10, 0, 0], "scale": 2,
                      "rotate": {"axis": [0, 0, 1], "degrees": 90}}}]})");
    const Scene s = LoadScene(file);
    ASSERT_EQ(s.triangles.size(), 1u);
    const Triangle& t = s.triangles[0];
    ExpectNear(t.p[0], {10, 0, 0});
    ExpectNear(t.p[1], {10, 2, 0});  // (1,0,0) scaled to (2,0,0), turned to (0,2,0)
    ExpectNear(t.p[2], {8, 0, 0});   // (0,1,0) scaled to (0,2,0), turned to (-2,0,0)
    ExpectNear(t.n[0], {0, 0, 1});
}

TEST(SceneFile, MatrixIsRowMajorAndNormalsUseTheInverseTranspose) {
    TempDir dir;
    // A slanted triangle whose normal (1,1,0)/sqrt2 must tilt under a non-uniform scale.
    dir.Write("slant.obj", "v 1 0 0\nv 0 1 0\nv 0 0 1\nvn 1 1 0\nf 1//1 2//1 3//1\n");
    const auto file = dir.Write("s.json", R"({"objects": [{"type": "mesh", "file": "slant.obj",
        "transform": {"matrix": [2, 0, 0, 5,  0, 1, 0, 6,  0, 0, 1, 7,  0, 0, 0, 1]}}]})");
    const Scene s = LoadScene(file);
    const Triangle& t = s.triangles[0];
    ExpectNear(t.p[0], {7, 6, 7});
    ExpectNear(t.p[1], {5, 7, 7});
    // Inverse transpose of diag(2,1,1) is diag(0.5,1,1): (0.5,1,0) renormalised.
    ExpectNear(t.n[0], glm::normalize(glm::vec3(0.5f, 1, 0)));
    ExpectNear(t.n[2], glm::normalize(glm::vec3(0.5f, 1, 0)));
}

TEST(SceneFile, MeshMaterialsComeFromTheMtlUnlessTheSceneNamesThem) {
    TempDir dir;
    dir.Write("m.mtl", "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n");
    dir.Write("two.obj",
              "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"
              "f 1 2 3\nusemtl red\nf 1 2 3\nusemtl blue\nf 1 2 3\n");
    const Scene s = LoadScene(dir.Write("s.json", R"({
        "materials": {"red": {"kd": [0.5, 0, 0]}, "white": {}},
        "objects": [{"type": "mesh", "file": "two.obj"},
                    {"type": "mesh", "file": "two.obj", "material": "white", "name": "plain"}]})"));
    ASSERT_EQ(s.materials.size(), 4u);
    EXPECT_EQ(s.materials[1].kd, glm::vec3(0.5f, 0, 0));  // the scene's "red" wins
    EXPECT_EQ(s.materials[3].name, "blue");
    EXPECT_EQ(s.materials[3].kd, glm::vec3(0, 0, 1));
    ASSERT_EQ(s.triangles.size(), 6u);
    EXPECT_EQ(s.triangles[0].material, 0u);  // before any usemtl
    EXPECT_EQ(s.triangles[1].material, 1u);
    EXPECT_EQ(s.triangles[2].material, 3u);
    for (int i = 3; i < 6; ++i) {
        EXPECT_EQ(s.triangles[i].material, 2u);  // the override
        EXPECT_EQ(s.triangles[i].object, 1u);
    }
    EXPECT_FALSE(s.triangles[0].hasNormals);
    EXPECT_EQ(s.objects[1].name, "plain");
}

TEST(SceneFile, KeepsZeroAreaTrianglesAndDropsUnusableNormals) {
    TempDir dir;
    dir.Write("odd.obj",
              "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nvn 0 0 1\n"
              "f 1 1 2\n"           // zero area
              "f 1//1 2//2 3//2\n"  // one zero normal
              "f 1//2 2 3//2\n");   // one corner without a normal
    const Scene s = LoadScene(dir.Write("s.json", R"({"objects": [{"type": "mesh",
        "file": "odd.obj"}]})"));
    ASSERT_EQ(s.triangles.size(), 3u);
    EXPECT_FALSE(s.triangles[1].hasNormals);
    EXPECT_FALSE(s.triangles[2].hasNormals);
}

TEST(SceneFile, DefaultMaterialCanBeRedefinedAndCameraDefaultsToFraming) {
    const TempDir dir;
    const Scene s = LoadScene(dir.Write("s.json", R"({"materials": {"default": {"kd": [1, 0, 1]}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}]})"));
    ASSERT_EQ(s.materials.size(), 1u);
    EXPECT_EQ(s.materials[0].kd, glm::vec3(1, 0, 1));
    const Camera framing = FramingCamera(s.Bounds(), 800, 600);
    EXPECT_EQ(s.camera.position, framing.position);
    EXPECT_EQ(s.camera.width, 800u);
    EXPECT_TRUE(s.lights.empty());
}

TEST(BareObj, FramesTheMeshAndLightsItFromTheCamera) {
    TempDir dir;
    dir.Write("m.mtl", "newmtl red\nKd 1 0 0\n");
    const auto file = dir.Write("quad.OBJ",
                                "mtllib m.mtl\nusemtl red\n"
                                "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n");
    const Scene s = LoadScene(file);
    ASSERT_EQ(s.triangles.size(), 2u);
    ASSERT_EQ(s.materials.size(), 2u);
    EXPECT_EQ(s.materials[1].name, "red");
    EXPECT_EQ(s.triangles[0].material, 1u);
    ASSERT_EQ(s.objects.size(), 1u);
    EXPECT_EQ(s.objects[0].name, "quad.OBJ");
    const Camera framing = FramingCamera(s.Bounds(), 800, 600);
    EXPECT_EQ(s.camera.position, framing.position);
    EXPECT_EQ(s.camera.lookAt, framing.lookAt);
    ASSERT_EQ(s.lights.size(), 1u);
    EXPECT_EQ(s.lights[0].position, s.camera.position);
    const float d = glm::length(s.camera.position - s.camera.lookAt);
    ExpectNear(s.lights[0].intensity / (d * d), glm::vec3(1));
    EXPECT_EQ(s.ambient, glm::vec3(0.05f));
}

TEST(BareObj, CornellBox) {
    TempDir dir;
    std::filesystem::copy_file(ScenesDir() / "tests" / "cornell_box_embree.obj",
                               dir.path() / "cornell_box.obj");
    dir.Write("cornell_box.mtl",
              "newmtl white\nKd 0.73\nnewmtl red\nKd 0.65 0.05 0.05\n"
              "newmtl green\nKd 0.12 0.45 0.15\nnewmtl blue\nKd 0.1 0.1 0.7\n"
              "newmtl light\nKd 0.78\nKe 15 15 15\n");
    const Scene s = LoadScene(dir.path() / "cornell_box.obj");
    EXPECT_EQ(s.triangles.size(), 36u);
    EXPECT_EQ(s.materials.size(), 6u);
    EXPECT_EQ(s.Bounds().hi, glm::vec3(556.0f, 548.8f, 559.2f));
}

TEST(SceneErrors, FileProblems) {
    TempDir dir;
    const auto missing = dir.path() / "none.json";
    EXPECT_EQ(ErrorOf([&] { LoadScene(missing); }), missing.string() + ": missing file");
    std::filesystem::create_directories(dir.path() / "d.json");
    EXPECT_EQ(ErrorOf([&] { LoadScene(dir.path() / "d.json"); }),
              (dir.path() / "d.json").string() + ": is a directory");
    const auto obj = dir.path() / "none.obj";
    EXPECT_EQ(ErrorOf([&] { LoadScene(obj); }), obj.string() + ": missing file");
    EXPECT_EQ(ErrorOf([&] { LoadScene("scene.yaml"); }),
              "scene.yaml: unknown scene file extension '.yaml' (expected .json or .obj)");
    const auto empty = dir.Write("empty.obj", "# nothing\n");
    EXPECT_EQ(ErrorOf([&] { LoadScene(empty); }), empty.string() + ": no triangles to render");
}

TEST(SceneErrors, JsonSyntaxErrorsGiveTheirLine) {
    EXPECT_EQ(JsonError("{\n  \"objects\": [\n    1,\n  }\n"),
              "4: syntax error while parsing value - unexpected '}'; expected '[', '{', or a "
              "literal");
    EXPECT_EQ(JsonError("{\n\"ambient\": [0, 0, 0]\n"),
              "3: syntax error while parsing object - unexpected end of input; expected '}'");
    EXPECT_EQ(JsonError(""),
              "1: syntax error while parsing value - unexpected end of input; expected '[', '{', "
              "or a literal");
    EXPECT_EQ(JsonError("{}\n\nx"),
              "3: syntax error while parsing value - invalid literal; expected end of input");
    EXPECT_EQ(JsonError("{\"a\":\n \"\\x\"}"),
              "2: syntax error while parsing value - invalid string: forbidden character after "
              "backslash");
    EXPECT_EQ(JsonError("{\"ambient\": [1e999, 0, 0]}"), "1: number overflow parsing '1e999'");
    EXPECT_EQ(JsonError("{\"lights\": [],\n \"lights\": []}"), "2: duplicate key 'lights'");
}

TEST(SceneErrors, DeepNestingIsRefused) {
    EXPECT_EQ(JsonError(std::string(100000, '[')), "1: nesting deeper than 64 levels");
    std::string nested = "{\"objects\": [";
    for (int i = 0; i < 70; ++i) nested += "{\"a\":\n";
    EXPECT_EQ(JsonError(nested), "63: nesting deeper than 64 levels");
}

TEST(SceneErrors, TopLevelAndSections) {
    EXPECT_EQ(JsonError("[1, 2]"), "1: scene: the top level must be a JSON object");
    EXPECT_EQ(JsonError("{\n\"objcts\": []}"), "2: scene: unknown key 'objcts'");
    EXPECT_EQ(JsonError("{\"objects\": {}}"), "1: scene: 'objects' must be an array");
    EXPECT_EQ(JsonError("{\"lights\": 3}"), "1: scene: 'lights' must be an array");
    EXPECT_EQ(JsonError("{\"materials\": []}"), "1: scene: 'materials' must be a JSON object");
    EXPECT_EQ(JsonError("{\"camera\": 1}"), "1: scene: 'camera' must be a JSON object");
    EXPECT_EQ(JsonError("{}"), "1: scene: no 'camera' and nothing to frame");
    EXPECT_EQ(JsonError("{\"ambient\": [1, -1, 0]}"),
              "1: scene: 'ambient' must be an array of 3 non-negative finite numbers");
    EXPECT_EQ(JsonError("{\"background\": [1, 1]}"),
              "1: scene: 'background' must be an array of 3 non-negative finite numbers");
}

TEST(SceneErrors, Objects) {
    EXPECT_EQ(JsonError(WithObject("{\"type\": \"sphere\", \"center\": [0, 0, 0]}")),
              "1: object 1: missing 'radius'");
    EXPECT_EQ(JsonError(R"({"objects": [
  {"type": "sphere", "center": [0, 0, 0], "radius": 1},
  {"type": "sphere", "center": [0, 0, 0],
   "raduis": 1}]})"),
              "4: object 2: unknown key 'raduis'");
    EXPECT_EQ(JsonError(WithObject(R"({"type": "sphere", "center": [0, 0, 0], "radius": 0})")),
              "1: object 1: 'radius' must be a positive number");
    EXPECT_EQ(JsonError(WithObject(R"({"type": "sphere", "center": [0, 0, 0], "radius": -2})")),
              "1: object 1: 'radius' must be a positive number");
    EXPECT_EQ(JsonError(WithObject(R"({"type": "sphere", "center": [0, 0, 0], "radius": "1"})")),
              "1: object 1: 'radius' must be a positive number");
    EXPECT_EQ(JsonError(WithObject(R"({"type": "sphere", "center": [0, 0], "radius": 1})")),
              "1: object 1: 'center' must be an array of 3 finite numbers");
    EXPECT_EQ(JsonError(WithObject(R"({"type": "sphere", "center": [0, 0, 0], "radius": 1e300})")),
              "1: object 1: 'radius' must be a positive number");
    EXPECT_EQ(JsonError(WithObject(R"({"type": "cube"})")),
              "1: object 1: unknown type 'cube' (expected mesh, sphere, quadric, bezier or nurbs)");
    EXPECT_EQ(JsonError(WithObject(R"({"center": [0, 0, 0]})")), "1: object 1: missing 'type'");
    EXPECT_EQ(JsonError(WithObject(R"({"type": 3})")), "1: object 1: 'type' must be a string");
    EXPECT_EQ(JsonError(WithObject("7")), "1: object 1: must be a JSON object");
    EXPECT_EQ(JsonError(WithObject(
                  R"({"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "foo"})")),
              "1: object 1: unknown material 'foo'");
    EXPECT_EQ(
        JsonError(WithObject(R"({"type": "sphere", "center": [0, 0, 0], "radius": 1, "name": 5})")),
        "1: object 1: 'name' must be a string");
    EXPECT_EQ(JsonError(WithObject(R"({"type": "quadric", "coefficients": [1, 2, 3],
                                       "box_min": [0, 0, 0], "box_max": [1, 1, 1]})")),
              "1: object 1: 'coefficients' must be an array of 10 finite numbers");
    EXPECT_EQ(JsonError(WithObject(R"({"type": "quadric",
        "coefficients": [1, 1, 1, 0, 0, 0, 0, 0, 0, -1],
        "box_min": [0, 2, 0],
        "box_max": [1, 1, 1]})")),
              "4: object 1: 'box_min' must not exceed 'box_max'");
}

TEST(SceneErrors, Meshes) {
    TempDir dir;
    dir.Write("tri.obj", kTriangleObj);
    EXPECT_EQ(JsonError(dir, WithObject(R"({"type": "mesh"})")), "1: object 1: missing 'file'");
    EXPECT_EQ(JsonError(dir, WithObject("{\"type\": \"mesh\",\n \"file\": \"gone.obj\"}")),
              "2: object 1: mesh '" + (dir.path() / "gone.obj").string() + "': missing file");
    const auto bad = dir.Write("bad.obj", "v 0 0 0\nf 1 2 3\n");
    EXPECT_EQ(JsonError(dir, WithObject(R"({"type": "mesh", "file": "bad.obj"})")),
              bad.string() + ":2: vertex index 2 out of range (1 vertex defined)");
    const auto mesh = [&](std::string_view transform) {
        return JsonError(dir, WithObject(R"({"type": "mesh", "file": "tri.obj", "transform": )" +
                                         std::string(transform) + "}"));
    };
    EXPECT_EQ(mesh(R"({"move": [1, 0, 0]})"), "1: object 1: unknown key 'move' in 'transform'");
    EXPECT_EQ(mesh(R"({"scale": 0})"),
              "1: object 1: 'scale' must be a non-zero finite number or an array of 3");
    EXPECT_EQ(mesh(R"({"scale": [1, 0, 1]})"),
              "1: object 1: 'scale' must be a non-zero finite number or an array of 3");
    EXPECT_EQ(mesh(R"({"translate": [1, 0]})"),
              "1: object 1: 'translate' must be an array of 3 finite numbers");
    EXPECT_EQ(mesh(R"({"rotate": {"axis": [0, 0, 0], "degrees": 3}})"),
              "1: object 1: 'axis' must not be zero");
    EXPECT_EQ(mesh(R"({"rotate": {"axis": [0, 1, 0]}})"),
              "1: object 1: 'rotate': missing 'degrees'");
    EXPECT_EQ(mesh(R"({"rotate": {"axis": [0, 1, 0], "degrees": 1, "angle": 2}})"),
              "1: object 1: unknown key 'angle' in 'rotate'");
    EXPECT_EQ(mesh(R"({"rotate": {"axis": [0, 1, 0], "degrees": "90"}})"),
              "1: object 1: 'degrees' must be a finite number");
    EXPECT_EQ(mesh(R"({"matrix": [1, 0, 0]})"),
              "1: object 1: 'matrix' must be an array of 16 finite numbers");
    EXPECT_EQ(mesh(R"({"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,1,1]})"),
              "1: object 1: 'matrix' must be affine (last row 0 0 0 1)");
    EXPECT_EQ(mesh(R"({"matrix": [1,0,0,0, 0,0,0,0, 0,0,1,0, 0,0,0,1]})"),
              "1: object 1: 'matrix' must be invertible");
    EXPECT_EQ(mesh(R"({"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "scale": 2})"),
              "1: object 1: 'matrix' cannot be combined with 'translate', 'scale' or 'rotate'");
    EXPECT_EQ(mesh("[]"), "1: object 1: 'transform' must be a JSON object");
}

TEST(SceneErrors, MaterialsLightsAndCamera) {
    EXPECT_EQ(JsonError("{\"materials\": {\"w\": {\"kdd\": [1, 1, 1]}}}"),
              "1: material 'w': unknown key 'kdd'");
    EXPECT_EQ(JsonError("{\"materials\": {\"w\": {\"kr\": -1}}}"),
              "1: material 'w': 'kr' must be a non-negative finite number or an array of 3");
    EXPECT_EQ(JsonError("{\"materials\": {\"w\": {\"ior\": 0}}}"),
              "1: material 'w': 'ior' must be a positive number");
    EXPECT_EQ(JsonError("{\"materials\": {\"w\": {\"shininess\": -1}}}"),
              "1: material 'w': 'shininess' must be a non-negative number");
    EXPECT_EQ(JsonError("{\"materials\": {\"w\": {\"fresnel\": 1}}}"),
              "1: material 'w': 'fresnel' must be true or false");
    EXPECT_EQ(JsonError("{\"materials\": {\"w\": 1}}"), "1: material 'w': must be a JSON object");
    EXPECT_EQ(JsonError("{\"lights\": [{\"intensity\": 1}]}"), "1: light 1: missing 'position'");
    EXPECT_EQ(JsonError("{\"lights\": [{\"position\": [0, 0, 0], \"intensity\": [1, 1]}]}"),
              "1: light 1: 'intensity' must be a non-negative finite number or an array of 3");

    const auto camera = [](std::string_view body) {
        return JsonError("{\"camera\": {" + std::string(body) + "}}");
    };
    EXPECT_EQ(camera(R"("width": 0)"), "1: camera: 'width' must be an integer in 1..16384");
    EXPECT_EQ(camera(R"("height": 16385)"), "1: camera: 'height' must be an integer in 1..16384");
    EXPECT_EQ(camera(R"("width": 800.5)"), "1: camera: 'width' must be an integer in 1..16384");
    EXPECT_EQ(camera(R"("width": -1)"), "1: camera: 'width' must be an integer in 1..16384");
    EXPECT_EQ(camera(R"("fov_y": 180)"),
              "1: camera: 'fov_y' must be a number between 0 and 180 (exclusive)");
    EXPECT_EQ(camera(R"("fov": 40)"), "1: camera: unknown key 'fov'");
    EXPECT_EQ(camera(R"("position": [0, 0, 0], "look_at": [0, 0, 0])"),
              "1: camera: 'look_at' must differ from 'position'");
    EXPECT_EQ(camera(R"("up": [0, 0, 2])"),
              "1: camera: 'up' must not be zero or parallel to the view direction");
    EXPECT_EQ(camera(R"("position": [0, "a", 0])"),
              "1: camera: 'position' must be an array of 3 finite numbers");
    const Scene s =
        LoadScene(TempDir().Write("c.json", R"({"camera": {"width": 16384, "height": 1}})"));
    EXPECT_EQ(s.camera.width, 16384u);
}

}  // namespace
}  // namespace rayclass::scene
