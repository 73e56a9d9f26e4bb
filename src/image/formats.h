// Internals shared by the OpenEXR and PNG codecs and image_io.cpp.
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

#include "rayclass/image/image.h"

namespace rayclass::image::detail {

// A file opened for binary writing that remembers the first OS error, so that codecs whose error
// paths cannot throw (libpng callbacks, OpenEXR destructors) still let the caller report it.
class OutFile {
  public:
    explicit OutFile(const std::filesystem::path& path);
    ~OutFile();
    OutFile(const OutFile&) = delete;
    OutFile& operator=(const OutFile&) = delete;

    bool Write(const void* data, size_t size) noexcept;
    bool Seek(uint64_t position) noexcept;
    uint64_t Tell() noexcept;
    bool Flush() noexcept;
    // Closes the file; buffered data reaches the disk here, so a full disk often shows up only now.
    bool Close() noexcept;

    bool Failed() const { return error_ != 0; }
    std::string Reason() const;

  private:
    bool Fail() noexcept;

    std::FILE* file_ = nullptr;
    int error_ = 0;  // errno of the first failure
};

// Codecs: each throws std::exception (any kind) carrying a bare reason; callers add the path.
void WriteExr(const Image& image, OutFile& file, const std::string& name,
              ExrCompression compression);
void WritePng(const Image& image, OutFile& file, float exposure, PngCompression compression);
Image ReadExr(const std::filesystem::path& file);
Image ReadPng(const std::filesystem::path& file);

// The PNG tone curve: linear radiance already scaled by exposure -> 8-bit sRGB, and back.
// EncodeSrgb8Formula is the definition (clamped to [0, 1], NaN to 0, the sRGB transfer
// function, rounded to the nearest step); EncodeSrgb8 gives the same byte from a table, without
// the formula's pow per value.
uint8_t EncodeSrgb8Formula(float linear);
uint8_t EncodeSrgb8(float linear);
float DecodeSrgb8(uint8_t value);

}  // namespace rayclass::image::detail
