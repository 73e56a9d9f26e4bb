#include <png.h>
#include <zlib.h>

#include <array>
#include <bit>
#include <cmath>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "formats.h"

namespace rayclass::image::detail {

namespace {

// libpng reports errors through a callback that must not return; it longjmps back to the
// setjmp in EncodePng. The message goes into a fixed buffer because nothing on that path may
// throw.
struct PngError {
    std::array<char, 256> message{};
};

[[noreturn]] void OnPngError(png_structp png, png_const_charp message) {
    auto* error = static_cast<PngError*>(png_get_error_ptr(png));
    std::snprintf(error->message.data(), error->message.size(), "%s", message);
    png_longjmp(png, 1);
}

void OnPngWarning(png_structp, png_const_charp) {}

void WritePngData(png_structp png, png_bytep data, size_t size) {
    // OutFile keeps the OS error; the caller reports that rather than this message.
    if (!static_cast<OutFile*>(png_get_io_ptr(png))->Write(data, size)) {
        png_error(png, "write failed");
    }
}

void FlushPngData(png_structp png) {
    if (!static_cast<OutFile*>(png_get_io_ptr(png))->Flush()) png_error(png, "flush failed");
}

// Frees libpng's state on every exit path.
struct PngWriter {
    png_structp png = nullptr;
    png_infop info = nullptr;
    ~PngWriter() { png_destroy_write_struct(&png, &info); }
};

// Every libpng call that can longjmp is here, in a frame that owns no object with a destructor
// (longjmp would skip it).
bool EncodePng(png_structp png, png_infop info, uint32_t width, uint32_t height, png_bytepp rows,
               PngCompression compression) {
    if (setjmp(png_jmpbuf(png))) return false;
    if (compression == PngCompression::kFast) {
        png_set_compression_level(png, 1);
        png_set_compression_strategy(png, Z_RLE);
        png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_UP);
    } else if (compression == PngCompression::kNone) {
        png_set_compression_level(png, 0);
        png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_NONE);
    }
    png_set_IHDR(png, info, width, height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    png_write_image(png, rows);
    png_write_end(png, nullptr);
    return true;
}

}  // namespace

namespace {

// NaN goes to black; the comparisons are written so that it falls through to 0.
float ClampUnit(float linear) { return linear > 0.0f ? (linear < 1.0f ? linear : 1.0f) : 0.0f; }

// EncodeSrgb8Formula over [0, 1] by the bits of the clamped value: their top 17 bits pick a
// bucket (2^15 floats, at most 0.4 % of the value wide), which holds its first float's byte and
// where the formula steps up, if it does. Adjacent bytes lie at least 0.89 % apart in linear
// value (the slope of the transfer function), so no bucket holds two steps (checked here).
class SrgbTable {
  public:
    SrgbTable() {
        // The first float of each step, by bisection over the bits: the formula does not
        // decrease (tests/image compare it with this table around every step).
        std::array<uint32_t, 255> step;
        for (int k = 0; k < 255; ++k) {
            uint32_t lo = 0, hi = std::bit_cast<uint32_t>(1.0f);  // f(lo) <= k < f(hi)
            while (hi - lo > 1) {
                const uint32_t mid = lo + (hi - lo) / 2;
                (EncodeSrgb8Formula(std::bit_cast<float>(mid)) > k ? hi : lo) = mid;
            }
            step[size_t(k)] = hi;
        }
        size_t k = 0;
        for (uint32_t b = 0; b < kBuckets; ++b) {
            const uint64_t end = uint64_t(b + 1) << kShift;
            base_[b] = uint8_t(k);
            next_[b] = k < 255 && step[k] < end ? step[k++] : UINT32_MAX;
            if (k < 255 && step[k] < end) throw std::logic_error("sRGB table: two steps a bucket");
        }
    }
    uint8_t operator()(float linear) const {
        const uint32_t bits = std::bit_cast<uint32_t>(ClampUnit(linear));
        const uint32_t b = bits >> kShift;
        return uint8_t(base_[b] + (bits >= next_[b] ? 1 : 0));
    }

  private:
    static constexpr int kShift = 15;
    static constexpr uint32_t kBuckets = (std::bit_cast<uint32_t>(1.0f) >> kShift) + 1;
    std::array<uint8_t, kBuckets> base_;
    std::array<uint32_t, kBuckets> next_;
};

}  // namespace

uint8_t EncodeSrgb8Formula(float linear) {
    const float v = ClampUnit(linear);
    float encoded = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
    return uint8_t(std::lround(encoded * 255.0f));
}

uint8_t EncodeSrgb8(float linear) {
    static const SrgbTable table;
    return table(linear);
}

float DecodeSrgb8(uint8_t value) {
    float v = float(value) / 255.0f;
    return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

void WritePng(const Image& image, OutFile& file, float exposure, PngCompression compression) {
    float scale = std::exp2(exposure);
    std::vector<png_byte> pixels(image.PixelCount() * 3);
    for (size_t i = 0; i < image.PixelCount(); ++i) {
        for (int c = 0; c < 3; ++c) pixels[3 * i + c] = EncodeSrgb8(image.rgb[i][c] * scale);
    }
    std::vector<png_bytep> rows(image.height);
    for (uint32_t y = 0; y < image.height; ++y) rows[y] = &pixels[size_t(y) * image.width * 3];

    PngError error;
    PngWriter writer;
    writer.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &error, OnPngError, OnPngWarning);
    if (!writer.png) throw std::runtime_error("cannot initialise libpng");
    writer.info = png_create_info_struct(writer.png);
    if (!writer.info) throw std::runtime_error("cannot initialise libpng");
    png_set_write_fn(writer.png, &file, WritePngData, FlushPngData);
    if (!EncodePng(writer.png, writer.info, image.width, image.height, rows.data(), compression)) {
        throw std::runtime_error(error.message.data());
    }
}

Image ReadPng(const std::filesystem::path& path) {
    // The simplified API reports errors in png_image::message; no longjmp reaches this frame.
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&png, path.c_str())) throw std::runtime_error(png.message);
    struct Guard {
        png_image& png;
        ~Guard() { png_image_free(&png); }
    } guard{png};
    // 8-bit sRGB; alpha is composited onto the zeroed buffer, i.e. onto black.
    png.format = PNG_FORMAT_RGB;
    std::vector<png_byte> pixels(PNG_IMAGE_SIZE(png));
    if (!png_image_finish_read(&png, nullptr, pixels.data(), 0, nullptr)) {
        throw std::runtime_error(png.message);
    }
    Image image(png.width, png.height);
    for (size_t i = 0; i < image.PixelCount(); ++i) {
        for (int c = 0; c < 3; ++c) image.rgb[i][c] = DecodeSrgb8(pixels[3 * i + c]);
    }
    return image;
}

}  // namespace rayclass::image::detail
