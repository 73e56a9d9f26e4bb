// Helpers shared by the OBJ/MTL and JSON readers (private to the scene module).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace rayclass::scene {

struct FileText {
    std::string text;
    std::string problem;  // empty on success, else "missing file", "is a directory", ...
};

// Largest input file read: line numbers (int) cannot overflow below it.
inline constexpr uint64_t kMaxInputBytes = (uint64_t(1) << 31) - 1;

// Reads a whole regular file of at most kMaxInputBytes; never throws for I/O problems, so each
// caller can place the error ("missing file", "is a directory", "is not a regular file",
// "file too large (...)", "cannot read file (...)").
FileText ReadFile(const std::filesystem::path& file);

// Splits text into logical lines: a trailing '\' joins the next physical line, '#' starts a
// comment, CR before LF is dropped. Lines come back with surrounding blanks trimmed.
class LineReader {
  public:
    // `linesBefore`: physical lines of the file before `text` (a piece of it), for the numbers.
    explicit LineReader(std::string_view text, int linesBefore = 0)
        : text_(text), physicalLine_(linesBefore) {}

    // Next non-empty logical line and the 1-based physical line it starts on; false at the end.
    bool Next(std::string_view& line, int& lineNumber);
    // Physical lines read so far, with linesBefore.
    int PhysicalLines() const { return physicalLine_; }

  private:
    std::string_view text_;
    size_t pos_ = 0;
    int physicalLine_;
    std::string joined_;  // holds a line built from continuations
};

inline bool IsBlank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// Removes and returns the first blank-separated token of `rest` (empty when none is left).
inline std::string_view NextToken(std::string_view& rest) {
    size_t i = 0;
    while (i < rest.size() && IsBlank(rest[i])) ++i;
    size_t j = i;
    while (j < rest.size() && !IsBlank(rest[j])) ++j;
    const std::string_view token = rest.substr(i, j - i);
    rest.remove_prefix(j);
    return token;
}

std::string_view Trim(std::string_view s);

// Whether the physical line that ends just before `end` (its '\n') continues onto the next one,
// as LineReader reads it: its text before any '#', trimmed, ends with '\'.
bool ContinuesBefore(std::string_view text, size_t end);

enum class NumberStatus { kOk, kMalformed, kNonFinite, kOutOfRange };

// Parses a whole token as a float (a leading '+' is accepted; values too small for a float
// become 0 or a subnormal, too large ones are kOutOfRange).
NumberStatus ParseFloat(std::string_view token, float& value);

}  // namespace rayclass::scene
