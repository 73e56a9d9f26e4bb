// Tiles of an image: TileRect's cover, crops in OpenEXR (data window inside the display window,
// the scene hash), and MergeTiles against the image the tiles were cut from.
#include "rayclass/image/tiles.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "rayclass/cli/cli.h"
#include "rayclass/core/error.h"
#include "rayclass/image/image.h"
#include "rayclass/image/merge.h"
#include "test_dir.h"

namespace rayclass::image {
namespace {

TEST(TileRect, TilesCoverTheImageOnceAndStayCompact) {
    const uint32_t sizes[][2] = {{800, 600}, {384, 216}, {61, 47}, {7, 300}, {1, 1}};
    for (const auto& [w, h] : sizes) {
        for (uint32_t n = 1; n <= 64 && n <= w * h; ++n) {
            SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h) + " in " + std::to_string(n));
            std::vector<uint8_t> hits(size_t(w) * h, 0);
            double worst = 1.0;
            for (uint32_t i = 0; i < n; ++i) {
                PixelRect r;
                try {
                    r = TileRect(i, n, w, h);
                } catch (const Error&) {
                    // Too many tiles for so few columns: then every index fails alike.
                    EXPECT_THROW(TileRect(0, n, w, h), Error);
                    hits.assign(hits.size(), 1);
                    break;
                }
                ASSERT_FALSE(r.Empty());
                ASSERT_TRUE(r.Inside(w, h));
                for (uint32_t y = r.y0; y < r.y1; ++y) {
                    for (uint32_t x = r.x0; x < r.x1; ++x) ++hits[size_t(y) * w + x];
                }
                const double aspect = double(r.Width()) / r.Height();
                worst = std::max(worst, std::max(aspect, 1.0 / aspect));
            }
            for (uint8_t k : hits) ASSERT_EQ(k, 1);
            // Compact: on a large image no tile is more than 2.5 times as long as it is wide
            // (one tile of a wide image is as wide as the image).
            if (w >= 384 && n > 1) {
                EXPECT_LE(worst, 2.5);
            }
        }
    }
}

TEST(TileRect, NumbersOutsideTheCountAndTooManyTilesAreRefused) {
    EXPECT_THROW(TileRect(4, 4, 100, 100), Error);
    EXPECT_THROW(TileRect(0, 0, 100, 100), Error);
    try {
        TileRect(0, 10, 2, 2);
        ADD_FAILURE() << "10 tiles of 2x2 pixels";
    } catch (const Error& e) {
        EXPECT_STREQ(e.what(), "10 tiles do not fit a 2x2 image");
    }
}

// A w x h image of distinct values in every layer.
Image Pattern(uint32_t w, uint32_t h, bool layers) {
    Image img(w, h);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-2.0f, 2.0f);
    for (auto& p : img.rgb) p = {u(rng), u(rng), u(rng)};
    if (layers) {
        img.depth.resize(img.PixelCount());
        img.id.resize(img.PixelCount());
        img.normal.resize(img.PixelCount());
        for (size_t i = 0; i < img.PixelCount(); ++i) {
            img.depth[i] = u(rng);
            img.id[i] = uint32_t(rng());
            img.normal[i] = {u(rng), u(rng), u(rng)};
        }
    }
    img.sceneHash = "0123456789abcdef";
    return img;
}

// `whole`'s pixels in `r`, placed there.
Image Cut(const Image& whole, const PixelRect& r) {
    Image t(r.Width(), r.Height());
    t.originX = r.x0;
    t.originY = r.y0;
    t.displayWidth = whole.width;
    t.displayHeight = whole.height;
    t.sceneHash = whole.sceneHash;
    const bool layers = !whole.depth.empty();
    if (layers) {
        t.depth.resize(t.PixelCount());
        t.id.resize(t.PixelCount());
        t.normal.resize(t.PixelCount());
    }
    for (uint32_t y = 0; y < t.height; ++y) {
        for (uint32_t x = 0; x < t.width; ++x) {
            const size_t i = size_t(y) * t.width + x, f = size_t(r.y0 + y) * whole.width + r.x0 + x;
            t.rgb[i] = whole.rgb[f];
            if (layers) {
                t.depth[i] = whole.depth[f];
                t.id[i] = whole.id[f];
                t.normal[i] = whole.normal[f];
            }
        }
    }
    return t;
}

bool SameBits(const Image& a, const Image& b) {
    auto same = [](const auto& x, const auto& y) {
        return x.size() == y.size() &&
               (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0);
    };
    return a.width == b.width && a.height == b.height && same(a.rgb, b.rgb) &&
           same(a.depth, b.depth) && same(a.id, b.id) && same(a.normal, b.normal);
}

class Tiles : public testing::TestDir {
  protected:
    // The tiles of `whole`, each written as OpenEXR and read back.
    std::vector<std::string> WriteTiles(const Image& whole, uint32_t n, const std::string& stem) {
        std::vector<std::string> files;
        for (uint32_t i = 0; i < n; ++i) {
            files.push_back(Path(stem + std::to_string(i) + ".exr").string());
            WriteImage(Cut(whole, TileRect(i, n, whole.width, whole.height)), files.back());
        }
        return files;
    }
    int Merge(std::vector<std::string> args) {
        std::ostringstream out, err;
        return cli::MergeCommand(args, out, err);
    }
    // The message MergeCommand fails with; the output must not exist afterwards.
    std::string MergeError(std::vector<std::string> args) {
        try {
            Merge(args);
        } catch (const std::exception& e) {
            EXPECT_FALSE(std::filesystem::exists(Path("out.exr")));
            return e.what();
        }
        ADD_FAILURE() << "merge succeeded";
        return "";
    }
};

TEST_F(Tiles, ACropKeepsItsPlaceAndSceneHashInOpenExr) {
    const Image whole = Pattern(37, 23, true);
    const PixelRect r{5, 9, 30, 20};
    WriteImage(Cut(whole, r), Path("crop.exr"));
    const Image back = ReadImage(Path("crop.exr"));
    EXPECT_EQ(back.originX, 5u);
    EXPECT_EQ(back.originY, 9u);
    EXPECT_EQ(back.DisplayWidth(), 37u);
    EXPECT_EQ(back.DisplayHeight(), 23u);
    EXPECT_EQ(back.sceneHash, "0123456789abcdef");
    EXPECT_TRUE(SameBits(back, Cut(whole, r)));
}

TEST_F(Tiles, MergedTilesAreTheWholeImage) {
    for (bool layers : {true, false}) {
        const Image whole = Pattern(61, 47, layers);
        for (uint32_t n : {1u, 3u, 4u, 7u}) {
            std::vector<std::string> args = {"-o", Path("out.exr").string()};
            for (const std::string& f : WriteTiles(whole, n, "t" + std::to_string(n) + "_")) {
                args.push_back(f);
            }
            ASSERT_EQ(Merge(args), 0);
            const Image merged = ReadImage(Path("out.exr"));
            EXPECT_TRUE(SameBits(merged, whole)) << n << " tiles";
            EXPECT_EQ(merged.sceneHash, whole.sceneHash);
            EXPECT_EQ(merged.originX, 0u);
            std::filesystem::remove(Path("out.exr"));
        }
    }
}

TEST_F(Tiles, MergeRefusesTilesThatDoNotMakeOneImageAndWritesNothing) {
    const Image whole = Pattern(40, 30, true);
    const std::vector<std::string> t = WriteTiles(whole, 4, "t");
    const std::string out = Path("out.exr").string();
    const std::string t0 = t[0], t1 = t[1], t2 = t[2], t3 = t[3];
    EXPECT_EQ(MergeError({"-o", out, t0, t1, t3}),
              "no tile covers pixels 0,15,20,30 of the 40x30 image (--allow-partial merges "
              "anyway)");
    EXPECT_EQ(MergeError({"-o", out, t0, t1, t2, t3, t1}),
              t1 + " (pixels 20,0,40,15) overlaps " + t1 + " (pixels 20,0,40,15)");
    // A crop overlapping two tiles.
    WriteImage(Cut(whole, {10, 10, 30, 20}), Path("crop.exr"));
    EXPECT_EQ(
        MergeError({"-o", out, t0, t1, Path("crop.exr").string()}),
        Path("crop.exr").string() + " (pixels 10,10,30,20) overlaps " + t0 + " (pixels 0,0,20,15)");
    // Another scene, another size, other layers.
    Image other = Cut(whole, TileRect(2, 4, 40, 30));
    other.sceneHash = "fedcba9876543210";
    WriteImage(other, Path("hash.exr"));
    EXPECT_EQ(MergeError({"-o", out, t0, t1, Path("hash.exr").string(), t3}),
              Path("hash.exr").string() + ": rendered from another scene or options than " + t0 +
                  " (scene hash fedcba9876543210 vs 0123456789abcdef)");
    WriteImage(Cut(Pattern(40, 31, true), TileRect(2, 4, 40, 30)), Path("size.exr"));
    EXPECT_EQ(MergeError({"-o", out, t0, Path("size.exr").string()}),
              Path("size.exr").string() + ": part of a 40x31 image, " + t0 + " of a 40x30 one");
    WriteImage(Cut(Pattern(40, 30, false), TileRect(2, 4, 40, 30)), Path("layers.exr"));
    EXPECT_EQ(MergeError({"-o", out, t0, Path("layers.exr").string()}),
              Path("layers.exr").string() + ": layers R,G,B differ from " + t0 +
                  "'s R,G,B,depth.Z,id.ID,normal.X,normal.Y,normal.Z");
    EXPECT_EQ(MergeError({"-o", out, t0, Path("missing.exr").string()})
                  .find(Path("missing.exr").string()),
              0u);
}

TEST_F(Tiles, AllowPartialLeavesTheMissingPixelsBlackAndMissed) {
    const Image whole = Pattern(40, 30, true);
    const std::vector<std::string> t = WriteTiles(whole, 4, "t");
    ASSERT_EQ(Merge({"-o", Path("out.exr").string(), "--allow-partial", t[0], t[3]}), 0);
    const Image merged = ReadImage(Path("out.exr"));
    for (uint32_t y = 0; y < 30; ++y) {
        for (uint32_t x = 0; x < 40; ++x) {
            const size_t i = size_t(y) * 40 + x;
            const bool covered = (x < 20) == (y < 15);
            if (covered) {
                ASSERT_EQ(merged.rgb[i], whole.rgb[i]);
                ASSERT_EQ(merged.id[i], whole.id[i]);
            } else {
                ASSERT_EQ(merged.rgb[i], glm::vec3(0.0f));
                ASSERT_EQ(merged.id[i], 0xFFFFFFFFu);
                ASSERT_TRUE(std::isinf(merged.depth[i]));
            }
        }
    }
}

}  // namespace
}  // namespace rayclass::image
