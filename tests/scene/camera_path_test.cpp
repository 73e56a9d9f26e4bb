// Camera paths: interpolation against its formulas, frame times, and the scene file's errors.
#include <gtest/gtest.h>

#include <string>

#include "rayclass/core/error.h"
#include "rayclass/scene/loader.h"
#include "rayclass/scene/scene.h"
#include "scene/test_files.h"

namespace rayclass::scene {
namespace {

using testing::ErrorOf;
using testing::TempDir;

CameraPath FourKeys(Interpolation interpolation) {
    CameraPath p;
    p.interpolation = interpolation;
    p.fps = 4;
    // Positions off a line, so Catmull-Rom and linear differ.
    p.keyframes = {{0.0, {0, 0, 10}, {0, 0, 0}},
                   {1.0, {4, 0, 10}, {1, 0, 0}},
                   {2.0, {4, 8, 10}, {2, 0, 0}},
                   {3.0, {0, 8, 12}, {3, 0, 0}}};
    return p;
}

TEST(CameraPath, FramesPassThroughTheKeyframesAndInterpolateBetween) {
    const Camera base;
    for (Interpolation in : {Interpolation::kLinear, Interpolation::kCatmullRom}) {
        const CameraPath p = FourKeys(in);
        EXPECT_EQ(p.FrameCount(), 13u);
        for (uint32_t k = 0; k < 4; ++k) {
            const Camera c = p.At(base, 4 * k);
            EXPECT_EQ(c.position, p.keyframes[k].position);
            EXPECT_EQ(c.lookAt, p.keyframes[k].lookAt);
            EXPECT_EQ(c.width, base.width);
        }
    }
    // Frame 6 is time 1.5, halfway between keyframes 1 and 2.
    const glm::vec3 p0(0, 0, 10), p1(4, 0, 10), p2(4, 8, 10), p3(0, 8, 12);
    EXPECT_EQ(FourKeys(Interpolation::kLinear).At(base, 6).position, (p1 + p2) * 0.5f);
    // Uniform Catmull-Rom at u = 1/2: (-p0 + 9 p1 + 9 p2 - p3) / 16.
    const glm::vec3 cr = FourKeys(Interpolation::kCatmullRom).At(base, 6).position;
    const glm::vec3 expected = (-p0 + 9.0f * p1 + 9.0f * p2 - p3) / 16.0f;
    EXPECT_NEAR(cr.x, expected.x, 1e-6f);
    EXPECT_NEAR(cr.y, expected.y, 1e-6f);
    EXPECT_NEAR(cr.z, expected.z, 1e-6f);
    try {
        FourKeys(Interpolation::kLinear).At(base, 13);
        ADD_FAILURE() << "frame 13 rendered";
    } catch (const Error& e) {
        EXPECT_STREQ(e.what(),
                     "frame 13 (time 3.250000) lies past the camera path's last keyframe (time "
                     "3.000000; frames 0..12)");
    }
}

TEST(CameraPath, SceneFilesReadItAndNameTheirMistakes) {
    const TempDir dir;
    const auto file = dir.Write("p.json", R"({"camera": {"position": [0, 0, 5], "path": {
        "interpolation": "catmull-rom", "fps": 2,
        "keyframes": [{"time": 1, "position": [0, 0, 5], "look_at": [0, 0, 0]},
                      {"time": 2, "position": [1, 0, 5], "look_at": [0, 1, 0]}]}}})");
    const Scene s = LoadScene(file);
    ASSERT_EQ(s.cameraPath.keyframes.size(), 2u);
    EXPECT_EQ(s.cameraPath.interpolation, Interpolation::kCatmullRom);
    EXPECT_EQ(s.cameraPath.fps, 2.0);
    EXPECT_EQ(s.cameraPath.keyframes[1].lookAt, glm::vec3(0, 1, 0));
    EXPECT_EQ(s.cameraPath.TimeOf(1), 1.5);

    const auto error = [&](std::string_view path) {
        const auto f = dir.Write("e.json", "{\"camera\": {\"path\": " + std::string(path) + "}}");
        return ErrorOf([&] { LoadScene(f); }).substr(f.string().size() + 1);
    };
    const std::string key0 = R"({"time": 0, "position": [0, 0, 1], "look_at": [0, 0, 0]})";
    EXPECT_EQ(error("{\"keyframes\": [" + key0 + "]}"),
              "1: camera path: 'keyframes' must be an array of at least 2 keyframes");
    EXPECT_EQ(error("{\"keyframes\": [" + key0 + ", " + key0 + "]}"),
              "1: camera path keyframe 2: 'time' must be later than the keyframe before");
    EXPECT_EQ(error("{\"interpolation\": \"cubic\", \"keyframes\": []}"),
              "1: camera path: 'interpolation' must be \"linear\" or \"catmull-rom\"");
    EXPECT_EQ(error("{\"fps\": 0, \"keyframes\": []}"),
              "1: camera path: 'fps' must be a number in (0, 1e6]");
    EXPECT_EQ(error(R"({"keyframes": [{"time": 0, "position": [0, 0, 1]}, 1]})"),
              "1: camera path keyframe 1: missing 'look_at'");
}

}  // namespace
}  // namespace rayclass::scene
