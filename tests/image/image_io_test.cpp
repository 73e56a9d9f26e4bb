#include <ImfChannelList.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfRgbaFile.h>
#include <ImfThreading.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <png.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>

#include "image/test_dir.h"
#include "rayclass/core/error.h"
#include "rayclass/image/image.h"

namespace rayclass::image {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::StartsWith;

constexpr float kInf = std::numeric_limits<float>::infinity();

class ImageIoTest : public testing::TestDir {};

template <typename T>
bool SameBits(const std::vector<T>& a, const std::vector<T>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

std::string ReadTextFile(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

Image AllLayers() {
    Image image(3, 2);
    image.depth.resize(6);
    image.id.resize(6);
    image.normal.resize(6);
    for (size_t i = 0; i < 6; ++i) {
        image.rgb[i] = glm::vec3(0.1f * float(i), 1e-7f * float(i), 1000.0f + float(i) / 3.0f);
        image.depth[i] = float(i) * 1.25f + 0.001f;
        image.id[i] = uint32_t(i) * 123457u;
        image.normal[i] = glm::normalize(glm::vec3(float(i) - 2.5f, 1.0f, 0.3f));
    }
    image.rgb[5] = glm::vec3(kInf, 0.0f, -0.0f);  // unusual values must survive too
    image.depth[5] = kInf;
    image.id[5] = 0xFFFFFFFFu;
    image.normal[5] = glm::vec3(0.0f);
    return image;
}

// Reads a PNG with libpng's simplified API as 8-bit RGB, as any other tool would see it.
std::vector<uint8_t> ReadPngBytes(const fs::path& file, uint32_t& width, uint32_t& height) {
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    EXPECT_TRUE(png_image_begin_read_from_file(&png, file.c_str())) << png.message;
    EXPECT_EQ(png.format, PNG_FORMAT_RGB);  // 8-bit RGB without alpha, as written
    png.format = PNG_FORMAT_RGB;
    std::vector<uint8_t> pixels(PNG_IMAGE_SIZE(png));
    EXPECT_TRUE(png_image_finish_read(&png, nullptr, pixels.data(), 0, nullptr)) << png.message;
    width = png.width;
    height = png.height;
    return pixels;
}

TEST_F(ImageIoTest, ExrRoundTripIsBitExact) {
    Image image = AllLayers();
    WriteImage(image, Path("all.exr"));
    Image back = ReadImage(Path("all.exr"));
    EXPECT_EQ(back.width, 3u);
    EXPECT_EQ(back.height, 2u);
    EXPECT_TRUE(SameBits(back.rgb, image.rgb));
    EXPECT_TRUE(SameBits(back.depth, image.depth));
    EXPECT_TRUE(SameBits(back.id, image.id));
    EXPECT_TRUE(SameBits(back.normal, image.normal));
}

TEST_F(ImageIoTest, ExrUsesDocumentedChannelsAndZip) {
    WriteImage(AllLayers(), Path("all.exr"));
    Imf::InputFile file(Path("all.exr").c_str());
    std::vector<std::string> names;
    for (auto it = file.header().channels().begin(); it != file.header().channels().end(); ++it) {
        names.push_back(it.name());
        EXPECT_EQ(it.channel().type, names.back() == "id.ID" ? Imf::UINT : Imf::FLOAT);
    }
    EXPECT_THAT(names,
                ElementsAre("B", "G", "R", "depth.Z", "id.ID", "normal.X", "normal.Y", "normal.Z"));
    EXPECT_EQ(file.header().compression(), Imf::ZIP_COMPRESSION);
}

TEST_F(ImageIoTest, EveryExrCompressionIsLosslessAndNamedInTheHeader) {
    const Image image = AllLayers();
    for (auto [compression, expected] : {std::pair{ExrCompression::kZip, Imf::ZIP_COMPRESSION},
                                         std::pair{ExrCompression::kPiz, Imf::PIZ_COMPRESSION},
                                         std::pair{ExrCompression::kNone, Imf::NO_COMPRESSION}}) {
        WriteOptions options;
        options.exrCompression = compression;
        WriteImage(image, Path("c.exr"), options);
        EXPECT_EQ(Imf::InputFile(Path("c.exr").c_str()).header().compression(), expected);
        const Image back = ReadImage(Path("c.exr"));
        EXPECT_TRUE(SameBits(back.rgb, image.rgb)) << int(expected);
        EXPECT_TRUE(SameBits(back.depth, image.depth)) << int(expected);
        EXPECT_TRUE(SameBits(back.id, image.id)) << int(expected);
        EXPECT_TRUE(SameBits(back.normal, image.normal)) << int(expected);
    }
}

// Many blocks of lines (ZIP packs 16 lines a block, PIZ 32), compressed and read on OpenEXR's
// threads: the file still holds every line where it belongs, and no thread outlives the call.
TEST_F(ImageIoTest, ExrOfManyLineBlocksRoundTripsOnOpenExrThreads) {
    Image image(257, 131);
    image.depth.resize(image.PixelCount());
    image.id.resize(image.PixelCount());
    image.normal.resize(image.PixelCount());
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> value(-10.0f, 10.0f);
    for (size_t i = 0; i < image.PixelCount(); ++i) {
        image.rgb[i] = glm::vec3(value(rng), value(rng), float(i));
        image.depth[i] = value(rng);
        image.id[i] = uint32_t(rng());
        image.normal[i] = glm::vec3(value(rng), float(i % 257), float(i / 257));
    }
    for (ExrCompression compression : {ExrCompression::kZip, ExrCompression::kPiz}) {
        WriteOptions options;
        options.exrCompression = compression;
        WriteImage(image, Path("big.exr"), options);
        EXPECT_EQ(Imf::globalThreadCount(), 0);
        const Image back = ReadImage(Path("big.exr"));
        EXPECT_EQ(Imf::globalThreadCount(), 0);
        EXPECT_TRUE(SameBits(back.rgb, image.rgb)) << int(compression);
        EXPECT_TRUE(SameBits(back.depth, image.depth)) << int(compression);
        EXPECT_TRUE(SameBits(back.id, image.id)) << int(compression);
        EXPECT_TRUE(SameBits(back.normal, image.normal)) << int(compression);
    }
}

TEST_F(ImageIoTest, ExrWithoutAovsReadsBackWithoutThem) {
    Image image(2, 2);
    image.rgb = {glm::vec3(1, 2, 3), glm::vec3(4, 5, 6), glm::vec3(7, 8, 9), glm::vec3(0.5f)};
    WriteImage(image, Path("rgb.EXR"));  // the extension is matched case-insensitively
    Image back = ReadImage(Path("rgb.EXR"));
    EXPECT_TRUE(SameBits(back.rgb, image.rgb));
    EXPECT_TRUE(back.depth.empty());
    EXPECT_TRUE(back.id.empty());
    EXPECT_TRUE(back.normal.empty());
}

TEST_F(ImageIoTest, ReadsHalfRgbaExrFromOtherTools) {
    // A data window away from the origin, as cropped renders from other tools have.
    Imath::Box2i window(Imath::V2i(10, 20), Imath::V2i(11, 20));
    Imf::Header header(window, window);
    std::vector<Imf::Rgba> pixels = {Imf::Rgba(0.5f, 0.25f, 2.0f, 1.0f),
                                     Imf::Rgba(0.0f, 1.0f, 0.125f, 0.5f)};
    {
        Imf::RgbaOutputFile out(Path("other.exr").c_str(), header, Imf::WRITE_RGBA);
        out.setFrameBuffer(pixels.data() - 10 - 20 * 2, 1, 2);
        out.writePixels(1);
    }
    Image back = ReadImage(Path("other.exr"));
    ASSERT_EQ(back.width, 2u);
    ASSERT_EQ(back.height, 1u);
    EXPECT_EQ(back.rgb[0], glm::vec3(0.5f, 0.25f, 2.0f));
    EXPECT_EQ(back.rgb[1], glm::vec3(0.0f, 1.0f, 0.125f));
    EXPECT_TRUE(back.id.empty());
}

TEST_F(ImageIoTest, ReadRejectsExrWithoutRgb) {
    Imf::Header header(1, 1);
    header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
    float y = 0.5f;
    Imf::FrameBuffer frame;
    frame.insert("Y", Imf::Slice::Make(Imf::FLOAT, &y, header.dataWindow()));
    {
        Imf::OutputFile out(Path("y.exr").c_str(), header);
        out.setFrameBuffer(frame);
        out.writePixels(1);
    }
    try {
        ReadImage(Path("y.exr"));
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()),
                  Path("y.exr").string() + ": cannot read: no full-resolution R, G and B channels");
    }
}

TEST_F(ImageIoTest, PngFollowsTheToneCurve) {
    Image image(4, 2);
    image.rgb = {glm::vec3(0.0f, 1.0f, 0.5f),
                 glm::vec3(2.0f, -1.0f, NAN),
                 glm::vec3(kInf, 0.0031308f, 0.2f),
                 glm::vec3(0.001f, 0.9f, 0.04f),
                 glm::vec3(0.25f),
                 glm::vec3(0.5f),
                 glm::vec3(1.0f),
                 glm::vec3(0.0f)};
    WriteImage(image, Path("tone.png"));
    uint32_t width = 0;
    uint32_t height = 0;
    std::vector<uint8_t> bytes = ReadPngBytes(Path("tone.png"), width, height);
    EXPECT_EQ(width, 4u);
    EXPECT_EQ(height, 2u);
    // sRGB OETF by hand: 0.5 -> 1.055 * 0.5^(1/2.4) - 0.055 = 0.7354 -> 187.5 -> 188.
    EXPECT_THAT(std::vector<uint8_t>(bytes.begin(), bytes.begin() + 12),
                ElementsAre(0, 255, 188, 255, 0, 0, 255, 10, 124, 3, 243, 56));
    EXPECT_THAT(std::vector<uint8_t>(bytes.begin() + 12, bytes.end()),
                ElementsAre(137, 137, 137, 188, 188, 188, 255, 255, 255, 0, 0, 0));
}

TEST_F(ImageIoTest, PngAppliesExposure) {
    Image image(1, 1);
    image.rgb = {glm::vec3(0.25f, 0.5f, 1.0f)};
    WriteImage(image, Path("exposed.Png"), {.exposure = 1.0f});
    uint32_t width = 0;
    uint32_t height = 0;
    EXPECT_THAT(ReadPngBytes(Path("exposed.Png"), width, height), ElementsAre(188, 255, 255));
}

// The compressions change the file, not its pixels: a render-like image (smooth shading with
// noise and edges) reads back the same from each, stored rows are the largest file and
// libpng's defaults the smallest.
TEST_F(ImageIoTest, EveryPngCompressionGivesTheSamePixels) {
    Image image(203, 97);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> noise(-0.02f, 0.02f);
    for (uint32_t y = 0; y < image.height; ++y) {
        for (uint32_t x = 0; x < image.width; ++x) {
            const float shade =
                (x / 40 + y / 30) % 2 ? float(x) / 203.0f : 0.8f - float(y) / 200.0f;
            image.rgb[size_t(y) * image.width + x] =
                glm::vec3(shade + noise(rng), 0.5f * shade, 0.25f + noise(rng));
        }
    }
    std::vector<std::vector<uint8_t>> pixels;
    std::vector<uintmax_t> sizes;
    for (PngCompression c :
         {PngCompression::kFast, PngCompression::kSmall, PngCompression::kNone}) {
        WriteImage(image, Path("c.png"), {.pngCompression = c});
        uint32_t width = 0, height = 0;
        pixels.push_back(ReadPngBytes(Path("c.png"), width, height));
        EXPECT_EQ(width, image.width);
        EXPECT_EQ(height, image.height);
        sizes.push_back(fs::file_size(Path("c.png")));
    }
    EXPECT_EQ(pixels[1], pixels[0]);
    EXPECT_EQ(pixels[2], pixels[0]);
    EXPECT_LT(sizes[1], sizes[0]);
    EXPECT_LT(sizes[0], sizes[2]);
    EXPECT_GT(sizes[2], image.PixelCount() * 3);  // stored: every byte and a filter byte a row
}

TEST_F(ImageIoTest, PngReadsBackAsLinear) {
    Image image(1, 1);
    image.rgb = {glm::vec3(0.0f, 0.5f, 1.0f)};
    WriteImage(image, Path("linear.png"));
    Image back = ReadImage(Path("linear.png"));
    EXPECT_EQ(back.rgb[0].x, 0.0f);
    EXPECT_NEAR(back.rgb[0].y, 0.5f, 0.005f);  // one 8-bit step near 0.5 is ~0.004 linear
    EXPECT_EQ(back.rgb[0].z, 1.0f);
}

TEST_F(ImageIoTest, UnsupportedExtensionIsRejected) {
    try {
        WriteImage(Image(1, 1), Path("out.xyz"));
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(
            std::string(e.what()),
            Path("out.xyz").string() + ": unsupported output format '.xyz' (use .exr or .png)");
    }
    EXPECT_TRUE(Entries().empty());
}

TEST_F(ImageIoTest, MissingDirectoryFailsAndLeavesNothing) {
    for (const char* name : {"dir_that_does_not_exist/x.exr", "dir_that_does_not_exist/x.png"}) {
        try {
            WriteImage(Image(2, 2), Path(name));
            FAIL() << "no error";
        } catch (const Error& e) {
            EXPECT_EQ(std::string(e.what()),
                      Path(name).string() + ": cannot write: No such file or directory");
        }
    }
    EXPECT_TRUE(Entries().empty());
}

TEST_F(ImageIoTest, OverwriteReplacesTheFileAndLeavesNoTemporary) {
    Image first(2, 1);
    first.rgb = {glm::vec3(1.0f), glm::vec3(2.0f)};
    Image second(1, 3);
    second.rgb = {glm::vec3(3.0f), glm::vec3(4.0f), glm::vec3(5.0f)};
    WriteImage(first, Path("x.exr"));
    WriteImage(second, Path("x.exr"));
    Image back = ReadImage(Path("x.exr"));
    EXPECT_EQ(back.width, 1u);
    EXPECT_TRUE(SameBits(back.rgb, second.rgb));
    EXPECT_THAT(Entries(), ElementsAre("x.exr"));
}

TEST_F(ImageIoTest, FailedRenameKeepsTheTargetAndRemovesTheTemporary) {
    // The target is a non-empty directory: the data is written, the final rename fails.
    fs::create_directory(Path("x.png"));
    std::ofstream(Path("x.png") / "keep") << "keep";
    try {
        WriteImage(Image(2, 2), Path("x.png"));
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_THAT(e.what(), StartsWith(Path("x.png").string() + ": cannot write: "));
    }
    EXPECT_TRUE(fs::is_regular_file(Path("x.png") / "keep"));
    EXPECT_THAT(Entries(), ElementsAre("x.png"));
}

// Writes `image` to `out` in a child process whose files may not grow beyond `limit` bytes
// (RLIMIT_FSIZE with SIGXFSZ ignored: write() fails with EFBIG at the limit, as it fails with
// ENOSPC on a full disk) and returns WriteImage's error message, or "" when it succeeded.
std::string WriteWithFileSizeLimit(const Image& image, const fs::path& out, rlim_t limit) {
    int fds[2];
    if (pipe(fds) != 0) {
        ADD_FAILURE() << "pipe: " << std::strerror(errno);
        return "";
    }
    const pid_t pid = fork();
    if (pid == 0) {
        close(fds[0]);
        std::signal(SIGXFSZ, SIG_IGN);
        const rlimit rl{limit, limit};
        std::string message = setrlimit(RLIMIT_FSIZE, &rl) == 0 ? "" : "setrlimit failed";
        if (message.empty()) {
            try {
                WriteImage(image, out);
            } catch (const std::exception& e) {
                message = e.what();
            }
        }
        const bool sent = write(fds[1], message.data(), message.size()) == ssize_t(message.size());
        _exit(sent ? 0 : 1);
    }
    close(fds[1]);
    std::string message;
    char buffer[512];
    for (ssize_t n; (n = read(fds[0], buffer, sizeof buffer)) > 0;)
        message.append(buffer, size_t(n));
    close(fds[0]);
    int status = 0;
    EXPECT_EQ(waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "child status " << status;
    return message;
}

TEST_F(ImageIoTest, FullDiskIsReportedAndKeepsThePreviousFile) {
    // Incompressible pixels, so both files are far larger than the stdio buffer and the first
    // limit; every layer, so the EXR writes several chunks.
    Image image(96, 64);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    image.depth.resize(image.PixelCount());
    image.id.resize(image.PixelCount());
    image.normal.resize(image.PixelCount());
    for (size_t i = 0; i < image.PixelCount(); ++i) {
        image.rgb[i] = glm::vec3(u(rng), u(rng), u(rng));
        image.depth[i] = u(rng);
        image.id[i] = uint32_t(rng());
        image.normal[i] = glm::vec3(u(rng), u(rng), u(rng));
    }
    for (const char* name : {"x.exr", "x.png"}) {
        // The size of the complete file, to place the limits.
        WriteImage(image, Path(name));
        const uintmax_t size = fs::file_size(Path(name));
        const std::string previous = std::string("the previous ") + name + "\n";
        std::ofstream(Path(name), std::ios::binary) << previous;
        // Nothing fits; the limit falls inside the data; only the last byte is missing (the
        // tail is still buffered when the codec returns: for the PNG only fclose fails).
        for (const rlim_t limit : {rlim_t(0), rlim_t(size / 3), rlim_t(size - 1)}) {
            EXPECT_EQ(WriteWithFileSizeLimit(image, Path(name), limit),
                      Path(name).string() + ": cannot write: File too large")
                << name << " (" << size << " bytes) with the limit at " << limit;
            EXPECT_TRUE(ReadTextFile(Path(name)) == previous)
                << name << ", limit " << limit << ": the previous file changed";
            EXPECT_THAT(Entries(), ElementsAre(name)) << "a temporary was left behind";
        }
        // The same child writes the file when the limit allows it.
        EXPECT_EQ(WriteWithFileSizeLimit(image, Path(name), rlim_t(size)), "") << name;
        EXPECT_EQ(fs::file_size(Path(name)), size) << name;
        fs::remove(Path(name));
    }
}

TEST_F(ImageIoTest, LayerSizeMismatchIsRejectedBeforeWriting) {
    Image image(2, 2);
    image.id = {1, 2, 3};
    try {
        WriteImage(image, Path("bad.exr"));
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()),
                  Path("bad.exr").string() + ": id layer has 3 values for 2x2 pixels");
    }
    EXPECT_TRUE(Entries().empty());
}

TEST_F(ImageIoTest, ReadErrorsNameTheFile) {
    try {
        ReadImage(Path("missing.exr"));
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()),
                  Path("missing.exr").string() + ": cannot read: No such file or directory");
    }
    std::ofstream(Path("text.exr")) << "not an image at all";
    try {
        ReadImage(Path("text.exr"));
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()),
                  Path("text.exr").string() + ": not an OpenEXR or PNG image");
    }
}

// OpenEXR allocates what a header attribute declares before reading it: a declared size beyond
// the file's end is refused first, with the attribute named.
TEST_F(ImageIoTest, ExrAttributeLargerThanTheFileIsAnError) {
    const char header[] =
        "v/1\x01\x02\0\0\0x\0opaque\0\xff\xff\xff\x7f"
        "abc";
    std::ofstream(Path("huge.exr"), std::ios::binary).write(header, sizeof(header) - 1);
    try {
        ReadImage(Path("huge.exr"));
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()),
                  Path("huge.exr").string() +
                      ": cannot read: header attribute 'x' declares 2147483647 bytes, but 3 "
                      "remain in the file");
    }
}

// The inputs fuzz_exr found (tests/fuzz/regressions/exr: a 2 GiB allocation, a timeout while
// ASan filled one, and a name longer than OpenEXR reads, after which its reader and a plain walk
// of the header disagree on where the next attribute starts) fail with the problem named.
TEST_F(ImageIoTest, FuzzFindingsAreErrors) {
    const char* source = std::getenv("RAYCLASS_SOURCE_DIR");
    const fs::path dir = fs::path(source ? source : ".") / "tests/fuzz/regressions/exr";
    size_t n = 0;
    for (const auto& entry : fs::directory_iterator(dir)) {
        ++n;
        try {
            ReadImage(entry.path());
            ADD_FAILURE() << entry.path() << ": no error";
        } catch (const Error& e) {
            EXPECT_THAT(e.what(), StartsWith(entry.path().string() + ": cannot read: header "));
        }
    }
    EXPECT_EQ(n, 3u);
}

TEST_F(ImageIoTest, TruncatedExrIsAnError) {
    Image image(64, 64);
    for (size_t i = 0; i < image.PixelCount(); ++i) image.rgb[i] = glm::vec3(float(i));
    WriteImage(image, Path("cut.exr"));
    fs::resize_file(Path("cut.exr"), fs::file_size(Path("cut.exr")) / 2);
    try {
        ReadImage(Path("cut.exr"));
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_THAT(e.what(), StartsWith(Path("cut.exr").string() + ": cannot read: "));
    }
}

}  // namespace
}  // namespace rayclass::image
