// A crop or tile of a render has the whole render's pixels, bit for bit, on every path: each ray
// query and kernel style, raster and kernel eye rays, the ray encodings and the reference.
#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "raster_support.h"
#include "rayclass/image/tiles.h"
#include "rayclass/render/cl_renderer.h"
#include "rayclass/render/reference.h"
#include "rayclass/scene/loader.h"

namespace rayclass::raster {
namespace {

using testing_support::Cl;
using testing_support::SceneDir;

// One way of rendering: the options and whether the eye rays' hits come from the raster pass.
struct Path {
    std::string name;
    render::RenderOptions options;
    bool raster = false;
    bool reference = false;
};

std::vector<Path> Paths() {
    std::vector<Path> paths;
    auto add = [&](std::string name, auto set, bool raster = false, bool reference = false) {
        Path p{std::move(name), {}, raster, reference};
        p.options.aovs = true;
        p.options.progress = false;
        set(p.options);
        paths.push_back(std::move(p));
    };
    using render::Accel;
    using render::KernelStyle;
    for (const auto& [name, style] : render::kKernelStyles) {
        add("classify/" + std::string(name), [style](auto& o) { o.kernel = style; });
    }
    add("bvh", [](auto& o) { o.accel = Accel::kBvh; });
    add("auto", [](auto& o) { o.accel = Accel::kAuto; });
    add("brute", [](auto& o) { o.accel = Accel::kBrute; });
    add("polar16", [](auto& o) { o.rayEncoding = render::RayEncoding::kPolar16; });
    add("watertight", [](auto& o) { o.triangleTest = render::TriangleTest::kWatertight; });
    // Small batches: a window's eye rays in several pages, classified from the camera.
    add("classify/batches", [](auto& o) { o.batchRays = 512; });
    add(
        "raster", [](auto&) {}, /*raster=*/true);
    add(
        "reference", [](auto&) {}, false, /*reference=*/true);
    return paths;
}

image::Image Render(const scene::Scene& scene, const Path& path, GlContext* gl,
                    const std::optional<image::PixelRect>& window) {
    render::RenderOptions options = path.options;
    options.window = window;
    render::RenderStats stats;
    if (path.reference) return render::RenderReference(scene, options, stats);
    std::unique_ptr<RasterEyeHits> eyeHits;
    if (path.raster) eyeHits = std::make_unique<RasterEyeHits>(*gl, RasterOptions{});
    return render::ClRenderer(Cl(), scene, options, eyeHits.get()).Render(stats);
}

// `crop` against `whole`'s pixels in its window, every layer compared by its bits.
void ExpectRegionOf(const image::Image& whole, const image::Image& crop,
                    const image::PixelRect& w) {
    ASSERT_EQ(crop.width, w.Width());
    ASSERT_EQ(crop.height, w.Height());
    EXPECT_EQ(crop.originX, w.x0);
    EXPECT_EQ(crop.originY, w.y0);
    EXPECT_EQ(crop.DisplayWidth(), whole.width);
    EXPECT_EQ(crop.DisplayHeight(), whole.height);
    ASSERT_EQ(crop.depth.size(), crop.PixelCount());
    ASSERT_EQ(crop.id.size(), crop.PixelCount());
    ASSERT_EQ(crop.normal.size(), crop.PixelCount());
    size_t differing = 0;
    for (uint32_t y = 0; y < crop.height; ++y) {
        for (uint32_t x = 0; x < crop.width; ++x) {
            const size_t c = size_t(y) * crop.width + x;
            const size_t f = size_t(w.y0 + y) * whole.width + w.x0 + x;
            const bool same =
                std::memcmp(&crop.rgb[c], &whole.rgb[f], sizeof(glm::vec3)) == 0 &&
                std::memcmp(&crop.depth[c], &whole.depth[f], sizeof(float)) == 0 &&
                crop.id[c] == whole.id[f] &&
                std::memcmp(&crop.normal[c], &whole.normal[f], sizeof(glm::vec3)) == 0;
            if (!same && differing++ < 3) {
                ADD_FAILURE() << "pixel (" << w.x0 + x << ", " << w.y0 + y << ") differs";
            }
        }
    }
    EXPECT_EQ(differing, 0u);
}

TEST(Crop, EveryPathGivesTheWholeRendersPixels) {
    GlContext* gl = testing_support::Gl();
    for (const char* file : {"cornell.json", "tests/glass.json", "tests/quadrics.json"}) {
        scene::Scene scene = scene::LoadScene(SceneDir() / file);
        scene.camera.width = 61;
        scene.camera.height = 47;
        // An odd crop away from every edge, a corner tile and a tile of one row.
        const image::PixelRect windows[] = {
            {13, 7, 50, 40}, image::TileRect(3, 4, 61, 47), {0, 46, 61, 47}};
        for (const Path& path : Paths()) {
            if (path.raster && !gl) {
                std::fprintf(stderr, "no OpenGL context: raster path not checked\n");
                continue;
            }
            SCOPED_TRACE(std::string(file) + " " + path.name);
            const image::Image whole = Render(scene, path, gl, std::nullopt);
            for (const image::PixelRect& w : windows) {
                SCOPED_TRACE("window " + w.ToString());
                ExpectRegionOf(whole, Render(scene, path, gl, w), w);
            }
        }
    }
}

TEST(Crop, AWindowOutsideTheImageIsRefused) {
    scene::Scene scene = scene::LoadScene(SceneDir() / "cornell.json");
    scene.camera.width = 40;
    scene.camera.height = 30;
    render::RenderOptions options;
    options.progress = false;
    render::RenderStats stats;
    for (const image::PixelRect& w :
         {image::PixelRect{0, 0, 41, 30}, image::PixelRect{5, 5, 5, 9}}) {
        options.window = w;
        try {
            render::ClRenderer(Cl(), scene, options).Render(stats);
            ADD_FAILURE() << "window " << w.ToString() << " was rendered";
        } catch (const Error& e) {
            EXPECT_EQ(std::string(e.what()),
                      "crop " + w.ToString() + " is not a non-empty part of the 40x30 image");
        }
    }
}

}  // namespace
}  // namespace rayclass::raster
