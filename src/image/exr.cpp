#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <ImfThreading.h>

#include <algorithm>
#include <climits>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

#include "formats.h"

namespace rayclass::image::detail {

namespace {

constexpr size_t kVec3Stride = sizeof(glm::vec3);
constexpr const char* kSceneHashAttribute = "rayclassSceneHash";
static_assert(kVec3Stride == 3 * sizeof(float), "glm::vec3 must be three packed floats");

// Routes OpenEXR's output through OutFile so the OS error of a failed write is kept.
class ExrStream : public Imf::OStream {
  public:
    ExrStream(OutFile& file, const std::string& name) : Imf::OStream(name.c_str()), file_(file) {}

    void write(const char c[], int n) override {
        if (!file_.Write(c, size_t(n))) throw std::runtime_error(file_.Reason());
    }
    uint64_t tellp() override { return file_.Tell(); }
    void seekp(uint64_t position) override {
        if (!file_.Seek(position)) throw std::runtime_error(file_.Reason());
    }

  private:
    OutFile& file_;
};

void AddChannel(Imf::Header& header, Imf::FrameBuffer& frame, const char* name, Imf::PixelType type,
                const void* base, size_t xStride, const Imath::Box2i& window) {
    header.channels().insert(name, Imf::Channel(type));
    frame.insert(name, Imf::Slice::Make(type, base, window, xStride));
}

// True when `name` is a full-resolution channel of the file.
bool HasChannel(const Imf::ChannelList& channels, const char* name) {
    const Imf::Channel* channel = channels.findChannel(name);
    return channel && channel->xSampling == 1 && channel->ySampling == 1;
}

// ZIP compression of a full-size image with its AOV layers takes about as long on one thread as
// a shallow render of a large scene; OpenEXR compresses and decompresses blocks of lines on
// the threads of its global pool. A file's thread count only sets how many blocks it keeps in
// flight: the pool starts with no threads, and every block then runs on the caller's. So each
// read or write sizes the pool to one thread per core and empties it again when done: no
// threads outlive the call (a process that forks later must not inherit a pool whose threads
// did not come along). The pool is global, hence one file at a time.
std::mutex exrPoolMutex;

class ExrThreads {
  public:
    ExrThreads() : lock_(exrPoolMutex) {
        Imf::setGlobalThreadCount(int(std::max(1u, std::thread::hardware_concurrency())));
    }
    ~ExrThreads() { Imf::setGlobalThreadCount(0); }
    ExrThreads(const ExrThreads&) = delete;
    ExrThreads& operator=(const ExrThreads&) = delete;
    int Count() const { return Imf::globalThreadCount(); }

  private:
    std::lock_guard<std::mutex> lock_;
};

}  // namespace

void WriteExr(const Image& image, OutFile& file, const std::string& name,
              ExrCompression compression) {
    if (uint64_t(image.originX) + image.width > image.DisplayWidth() ||
        uint64_t(image.originY) + image.height > image.DisplayHeight()) {
        throw std::runtime_error("pixels outside the display window");
    }
    if (image.DisplayWidth() > INT_MAX || image.DisplayHeight() > INT_MAX)
        throw std::runtime_error("image too large");
    const Imath::Box2i display({0, 0},
                               {int(image.DisplayWidth()) - 1, int(image.DisplayHeight()) - 1});
    const Imath::Box2i data(
        {int(image.originX), int(image.originY)},
        {int(image.originX + image.width) - 1, int(image.originY + image.height) - 1});
    Imf::Header header(display, data);
    if (!image.sceneHash.empty()) {
        header.insert(kSceneHashAttribute, Imf::StringAttribute(image.sceneHash));
    }
    header.compression() = compression == ExrCompression::kZip   ? Imf::ZIP_COMPRESSION
                           : compression == ExrCompression::kPiz ? Imf::PIZ_COMPRESSION
                                                                 : Imf::NO_COMPRESSION;
    // zlib's fastest level: the mantissas' low bytes are noise that no level finds matches in, so
    // the slower levels buy a fraction of a percent of the file for their time.
    header.zipCompressionLevel() = 1;
    const Imath::Box2i& window = header.dataWindow();
    Imf::FrameBuffer frame;
    const glm::vec3* rgb = image.rgb.data();
    AddChannel(header, frame, "R", Imf::FLOAT, &rgb->x, kVec3Stride, window);
    AddChannel(header, frame, "G", Imf::FLOAT, &rgb->y, kVec3Stride, window);
    AddChannel(header, frame, "B", Imf::FLOAT, &rgb->z, kVec3Stride, window);
    if (!image.depth.empty()) {
        AddChannel(header, frame, "depth.Z", Imf::FLOAT, image.depth.data(), sizeof(float), window);
    }
    if (!image.id.empty()) {
        AddChannel(header, frame, "id.ID", Imf::UINT, image.id.data(), sizeof(uint32_t), window);
    }
    if (!image.normal.empty()) {
        const glm::vec3* normal = image.normal.data();
        AddChannel(header, frame, "normal.X", Imf::FLOAT, &normal->x, kVec3Stride, window);
        AddChannel(header, frame, "normal.Y", Imf::FLOAT, &normal->y, kVec3Stride, window);
        AddChannel(header, frame, "normal.Z", Imf::FLOAT, &normal->z, kVec3Stride, window);
    }
    ExrStream stream(file, name);
    const ExrThreads threads;
    // The line offset table is written by the destructor, which swallows errors; OutFile keeps
    // them for the caller.
    Imf::OutputFile output(stream, header, threads.Count());
    output.setFrameBuffer(frame);
    output.writePixels(int(image.height));
}

namespace {

// The scene hash, and a crop's place in the display window when the file's data window lies
// inside a display window that starts at (0, 0); any other file is an image of its own.
void ReadPlacement(const Imf::Header& header, Image& image) {
    if (const auto* hash = header.findTypedAttribute<Imf::StringAttribute>(kSceneHashAttribute)) {
        image.sceneHash = hash->value();
    }
    const Imath::Box2i& data = header.dataWindow();
    const Imath::Box2i& display = header.displayWindow();
    if (display.min.x != 0 || display.min.y != 0 || data.min.x < 0 || data.min.y < 0 ||
        data.max.x > display.max.x || data.max.y > display.max.y) {
        return;
    }
    image.originX = uint32_t(data.min.x);
    image.originY = uint32_t(data.min.y);
    image.displayWidth = uint32_t(display.max.x + 1);
    image.displayHeight = uint32_t(display.max.y + 1);
}

// Reads a NUL-terminated header string of at most `limit` characters (31, or 255 in files that
// declare long names: what OpenEXR reads, so that both walk the header alike).
std::string HeaderString(std::ifstream& in, size_t limit) {
    std::string s;
    for (char c; in.get(c);) {
        if (c == '\0') return s;
        if (s.size() == limit) {
            throw std::runtime_error("header name longer than " + std::to_string(limit) +
                                     " characters");
        }
        s.push_back(c);
    }
    throw std::runtime_error("header ends early");
}

uint32_t HeaderUint(std::ifstream& in) {
    unsigned char b[4];
    if (!in.read(reinterpret_cast<char*>(b), sizeof(b))) {
        throw std::runtime_error("header ends early");
    }
    return uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24;
}

// The bytes OpenEXR reads for a value of `type` that declares `size` bytes, read past here.
// Its reader takes fixed-size types at their size and channel lists and previews by their
// content, whatever the declared size, so a file whose sizes disagree puts the two walks out of
// step; other types (strings, unknown ones) take the declared size.
uint64_t ValueBytes(std::ifstream& in, const std::string& type, size_t limit, uint32_t size) {
    static const std::pair<const char*, uint32_t> kFixed[] = {
        {"box2i", 16},      {"box2f", 16},   {"chromaticities", 32},
        {"compression", 1}, {"double", 8},   {"envmap", 1},
        {"float", 4},       {"int", 4},      {"keycode", 28},
        {"lineOrder", 1},   {"m33f", 36},    {"m33d", 72},
        {"m44f", 64},       {"m44d", 128},   {"rational", 8},
        {"tiledesc", 9},    {"timecode", 8}, {"v2i", 8},
        {"v2f", 8},         {"v2d", 16},     {"v3i", 12},
        {"v3f", 12},        {"v3d", 24},     {"deepImageState", 1}};
    const std::streamoff start = in.tellg();
    uint64_t read = size;
    for (const auto& [name, bytes] : kFixed) {
        if (type == name) read = bytes;
    }
    if (type == "chlist") {
        while (!HeaderString(in, limit).empty()) {
            if (!in.seekg(16, std::ios::cur)) throw std::runtime_error("header ends early");
        }
        read = uint64_t(in.tellg() - start);
    } else if (type == "preview") {
        const uint64_t width = HeaderUint(in), height = HeaderUint(in);
        read = 8 + 4 * width * height;
    }
    in.seekg(start + std::streamoff(size));
    return read;
}

// OpenEXR sizes its line buffers by the data window before reading a pixel, so a few bytes can
// claim gigabytes (found by fuzz_exr). rayclass renders at most 16384 x 16384 pixels and reads
// no larger image. Leaves the stream where it was.
void CheckWindow(std::ifstream& in) {
    constexpr int64_t kMaxSide = 16384;
    const std::streamoff start = in.tellg();
    int64_t v[4];
    for (int64_t& x : v) x = int32_t(HeaderUint(in));
    const int64_t width = v[2] - v[0] + 1, height = v[3] - v[1] + 1;
    if (width < 1 || height < 1 || width > kMaxSide || height > kMaxSide) {
        throw std::runtime_error("header data window of " + std::to_string(width) + " x " +
                                 std::to_string(height) + " pixels (at most " +
                                 std::to_string(kMaxSide) + " a side)");
    }
    in.seekg(start);
}

// OpenEXR's reader allocates the size an attribute declares before reading it, so that a few
// bytes claiming 2 GiB cost 2 GiB (found by tests/fuzz/fuzz_exr.cpp). Every header's attribute
// sizes are checked against what the file holds, and against what OpenEXR will read for the
// value, before OpenEXR sees it.
void CheckAttributeSizes(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    const uint64_t fileSize = std::filesystem::file_size(path);
    unsigned char version[8];
    if (!in.read(reinterpret_cast<char*>(version), sizeof(version))) {
        throw std::runtime_error("header ends early");
    }
    // Flag bits 10 (long names) and 12 (multipart) of the version field.
    const size_t limit = (version[5] & 0x04) != 0 ? 255 : 31;
    const bool multipart = (version[5] & 0x10) != 0;
    do {
        for (std::string name = HeaderString(in, limit); !name.empty();
             name = HeaderString(in, limit)) {
            const std::string type = HeaderString(in, limit);
            const int32_t size = int32_t(HeaderUint(in));
            const uint64_t left = fileSize - uint64_t(in.tellg());
            if (size < 0 || uint64_t(size) > left) {
                throw std::runtime_error("header attribute '" + name + "' declares " +
                                         std::to_string(size) + " bytes, but " +
                                         std::to_string(left) + " remain in the file");
            }
            if (name == "dataWindow" && type == "box2i" && size == 16) CheckWindow(in);
            const uint64_t read = ValueBytes(in, type, limit, uint32_t(size));
            if (read != uint64_t(size)) {
                throw std::runtime_error("header attribute '" + name + "' of type '" + type +
                                         "' declares " + std::to_string(size) +
                                         " bytes, but its value takes " + std::to_string(read));
            }
        }
    } while (multipart && in.peek() != 0 && in.peek() != std::ifstream::traits_type::eof());
}

}  // namespace

Image ReadExr(const std::filesystem::path& path) {
    CheckAttributeSizes(path);
    const ExrThreads threads;
    Imf::InputFile input(path.c_str(), threads.Count());
    const Imf::Header& header = input.header();
    const Imath::Box2i& window = header.dataWindow();
    const Imf::ChannelList& channels = header.channels();
    if (!HasChannel(channels, "R") || !HasChannel(channels, "G") || !HasChannel(channels, "B")) {
        throw std::runtime_error("no full-resolution R, G and B channels");
    }
    Image image(uint32_t(window.max.x - window.min.x + 1),
                uint32_t(window.max.y - window.min.y + 1));
    ReadPlacement(header, image);
    Imf::FrameBuffer frame;
    auto insert = [&](const char* name, Imf::PixelType type, void* base, size_t xStride) {
        frame.insert(name, Imf::Slice::Make(type, base, window, xStride));
    };
    glm::vec3* rgb = image.rgb.data();
    insert("R", Imf::FLOAT, &rgb->x, kVec3Stride);
    insert("G", Imf::FLOAT, &rgb->y, kVec3Stride);
    insert("B", Imf::FLOAT, &rgb->z, kVec3Stride);
    if (HasChannel(channels, "depth.Z")) {
        image.depth.resize(image.PixelCount());
        insert("depth.Z", Imf::FLOAT, image.depth.data(), sizeof(float));
    }
    if (HasChannel(channels, "id.ID")) {
        image.id.resize(image.PixelCount());
        insert("id.ID", Imf::UINT, image.id.data(), sizeof(uint32_t));
    }
    if (HasChannel(channels, "normal.X") && HasChannel(channels, "normal.Y") &&
        HasChannel(channels, "normal.Z")) {
        image.normal.resize(image.PixelCount());
        glm::vec3* normal = image.normal.data();
        insert("normal.X", Imf::FLOAT, &normal->x, kVec3Stride);
        insert("normal.Y", Imf::FLOAT, &normal->y, kVec3Stride);
        insert("normal.Z", Imf::FLOAT, &normal->z, kVec3Stride);
    }
    input.setFrameBuffer(frame);
    input.readPixels(window.min.y, window.max.y);
    return image;
}

}  // namespace rayclass::image::detail
