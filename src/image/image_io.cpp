#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <exception>
#include <stdexcept>
#include <string>
#include <system_error>

#include "formats.h"
#include "rayclass/core/error.h"
#include "rayclass/image/image.h"

namespace rayclass::image {

namespace fs = std::filesystem;

namespace detail {

OutFile::OutFile(const fs::path& path) : file_(std::fopen(path.c_str(), "wb")) {
    if (!file_) Fail();
}

OutFile::~OutFile() {
    if (file_) std::fclose(file_);
}

bool OutFile::Fail() noexcept {
    // A short write may leave errno unset; it is still an I/O error.
    if (error_ == 0) error_ = errno != 0 ? errno : EIO;
    return false;
}

bool OutFile::Write(const void* data, size_t size) noexcept {
    if (Failed() || !file_) return false;
    errno = 0;
    return std::fwrite(data, 1, size, file_) == size || Fail();
}

bool OutFile::Seek(uint64_t position) noexcept {
    if (Failed() || !file_) return false;
    errno = 0;
    return fseeko(file_, off_t(position), SEEK_SET) == 0 || Fail();
}

uint64_t OutFile::Tell() noexcept {
    if (Failed() || !file_) return 0;
    errno = 0;
    off_t position = ftello(file_);
    if (position < 0) {
        Fail();
        return 0;
    }
    return uint64_t(position);
}

bool OutFile::Flush() noexcept {
    if (Failed() || !file_) return false;
    errno = 0;
    return std::fflush(file_) == 0 || Fail();
}

bool OutFile::Close() noexcept {
    if (!file_) return false;
    errno = 0;
    int result = std::fclose(file_);
    file_ = nullptr;
    return (result == 0 && !Failed()) || Fail();
}

std::string OutFile::Reason() const { return std::strerror(error_); }

}  // namespace detail

namespace {

enum class Format { kExr, kPng };

Format FormatOf(const fs::path& out) {
    std::string ext = out.extension().string();
    std::string lower = ext;
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    if (lower == ".exr") return Format::kExr;
    if (lower == ".png") return Format::kPng;
    throw Error(out.string() + ": unsupported output format '" + ext + "' (use .exr or .png)");
}

void CheckLayers(const Image& image, const fs::path& out) {
    size_t pixels = image.PixelCount();
    auto check = [&](size_t size, const char* layer, bool optional) {
        if (size != pixels && !(optional && size == 0)) {
            throw Error(out.string() + ": " + layer + " layer has " + std::to_string(size) +
                        " values for " + std::to_string(image.width) + "x" +
                        std::to_string(image.height) + " pixels");
        }
    };
    if (pixels == 0) throw Error(out.string() + ": cannot write an empty image");
    check(image.rgb.size(), "rgb", false);
    check(image.depth.size(), "depth", true);
    check(image.id.size(), "id", true);
    check(image.normal.size(), "normal", true);
}

}  // namespace

void WriteImage(const Image& image, const fs::path& out, const WriteOptions& options) {
    Format format = FormatOf(out);
    CheckLayers(image, out);
    // Beside the target, so the rename stays within one file system and is atomic.
    // Built by appending: "." + name trips a false -Wrestrict in GCC 12 (bug 105329).
    std::string tempName(1, '.');
    tempName += out.filename().string();
    tempName += ".tmp-" + std::to_string(getpid());
    fs::path temp = out.parent_path() / tempName;
    try {
        detail::OutFile file(temp);
        if (file.Failed()) throw std::runtime_error(file.Reason());
        try {
            if (format == Format::kExr) {
                detail::WriteExr(image, file, out.string(), options.exrCompression);
            } else {
                detail::WritePng(image, file, options.exposure, options.pngCompression);
            }
        } catch (const std::exception&) {
            // The codec's own message is less precise than the OS error that caused it.
            if (file.Failed()) throw std::runtime_error(file.Reason());
            throw;
        }
        if (!file.Close()) throw std::runtime_error(file.Reason());
        fs::rename(temp, out);
    } catch (const std::exception& e) {
        std::error_code ignored;
        fs::remove(temp, ignored);
        const auto* fsError = dynamic_cast<const fs::filesystem_error*>(&e);
        std::string reason = fsError ? fsError->code().message() : e.what();
        throw Error(out.string() + ": cannot write: " + reason);
    }
}

Image ReadImage(const fs::path& file) {
    // Sniff the content first, so a missing file or a foreign format gets a plain message.
    std::array<unsigned char, 8> magic{};
    size_t got = 0;
    {
        std::FILE* f = std::fopen(file.c_str(), "rb");
        if (!f) throw Error(file.string() + ": cannot read: " + std::strerror(errno));
        got = std::fread(magic.data(), 1, magic.size(), f);
        bool failed = std::ferror(f) != 0;
        int error = errno;
        std::fclose(f);
        if (failed) throw Error(file.string() + ": cannot read: " + std::strerror(error));
    }
    static constexpr std::array<unsigned char, 4> kExrMagic = {0x76, 0x2f, 0x31, 0x01};
    static constexpr std::array<unsigned char, 8> kPngMagic = {0x89, 'P',  'N',  'G',
                                                               '\r', '\n', 0x1a, '\n'};
    bool exr =
        got >= kExrMagic.size() && std::equal(kExrMagic.begin(), kExrMagic.end(), magic.begin());
    bool png =
        got >= kPngMagic.size() && std::equal(kPngMagic.begin(), kPngMagic.end(), magic.begin());
    if (!exr && !png) throw Error(file.string() + ": not an OpenEXR or PNG image");
    try {
        return exr ? detail::ReadExr(file) : detail::ReadPng(file);
    } catch (const std::exception& e) {
        throw Error(file.string() + ": cannot read: " + e.what());
    }
}

}  // namespace rayclass::image
