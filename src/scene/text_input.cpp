#include "text_input.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstring>

namespace rayclass::scene {

namespace {

// Closes the descriptor on every path out of ReadFile.
struct FileDescriptor {
    int fd;
    ~FileDescriptor() {
        if (fd >= 0) ::close(fd);
    }
};

std::string SystemProblem(int error) {
    return std::string("cannot read file (") + std::strerror(error) + ")";
}

}  // namespace

FileText ReadFile(const std::filesystem::path& file) {
    FileText result;
    // O_NONBLOCK: opening a FIFO must not wait for a writer (it is refused below anyway).
    const FileDescriptor in{::open(file.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK)};
    if (in.fd < 0) {
        result.problem =
            errno == ENOENT || errno == ENOTDIR ? "missing file" : SystemProblem(errno);
        return result;
    }
    struct stat info {};
    if (::fstat(in.fd, &info) != 0) {
        result.problem = SystemProblem(errno);
        return result;
    }
    if (S_ISDIR(info.st_mode)) {
        result.problem = "is a directory";
        return result;
    }
    // Devices, FIFOs and sockets may never end (/dev/zero) or never start (a FIFO without a
    // writer): only regular files are read.
    if (!S_ISREG(info.st_mode)) {
        result.problem = "is not a regular file";
        return result;
    }
    if (uint64_t(info.st_size) > kMaxInputBytes) {
        result.problem = "file too large (" + std::to_string(info.st_size) + " bytes, at most " +
                         std::to_string(kMaxInputBytes) + ")";
        return result;
    }
    // st_size is where reading starts; a file that grows meanwhile is read up to the limit. The
    // byte beyond it takes the read that finds the end: without it that read would first grow
    // the string, copying the whole file into fresh pages.
    result.text.resize(size_t(info.st_size) + 1);
    size_t used = 0;
    for (;;) {
        if (used == result.text.size()) {
            if (used >= kMaxInputBytes) {
                result.text.clear();
                result.problem = "file too large (more than " + std::to_string(kMaxInputBytes) +
                                 " bytes)";
                return result;
            }
            result.text.resize(std::min<size_t>(used + 65536, kMaxInputBytes));
        }
        const ssize_t n = ::read(in.fd, result.text.data() + used, result.text.size() - used);
        if (n < 0) {
            if (errno == EINTR) continue;
            result.text.clear();
            result.problem = SystemProblem(errno);
            return result;
        }
        if (n == 0) break;
        used += size_t(n);
    }
    result.text.resize(used);
    return result;
}

std::string_view Trim(std::string_view s) {
    while (!s.empty() && IsBlank(s.front())) s.remove_prefix(1);
    while (!s.empty() && IsBlank(s.back())) s.remove_suffix(1);
    return s;
}

namespace {

// A physical line (without its '\n') as LineReader reads it: the comment cut off, trimmed.
std::string_view Uncommented(std::string_view physical) {
    if (const void* hash = std::memchr(physical.data(), '#', physical.size())) {
        physical = physical.substr(0, size_t(static_cast<const char*>(hash) - physical.data()));
    }
    return Trim(physical);
}

// Whether an uncommented physical line continues onto the next: a '\' inside a comment
// continues nothing.
bool Continues(std::string_view s) { return !s.empty() && s.back() == '\\'; }

}  // namespace

bool ContinuesBefore(std::string_view text, size_t end) {
    const size_t newline = end == 0 ? std::string_view::npos : text.rfind('\n', end - 1);
    const size_t start = newline == std::string_view::npos ? 0 : newline + 1;
    return Continues(Uncommented(text.substr(start, end - start)));
}

bool LineReader::Next(std::string_view& line, int& lineNumber) {
    const auto readPhysical = [this]() {
        const char* start = text_.data() + pos_;
        const size_t left = text_.size() - pos_;
        const void* newline = std::memchr(start, '\n', left);
        const size_t length = newline ? size_t(static_cast<const char*>(newline) - start) : left;
        pos_ += newline ? length + 1 : length;
        ++physicalLine_;
        return Uncommented(std::string_view(start, length));
    };

    while (pos_ < text_.size()) {
        lineNumber = physicalLine_ + 1;
        std::string_view logical = readPhysical();
        if (Continues(logical)) {
            joined_.assign(logical.substr(0, logical.size() - 1));
            std::string_view next = logical;
            while (Continues(next) && pos_ < text_.size()) {
                next = readPhysical();
                joined_ += ' ';
                joined_ += Continues(next) ? next.substr(0, next.size() - 1) : next;
            }
            logical = Trim(joined_);
        }
        if (!logical.empty()) {
            line = logical;
            return true;
        }
    }
    return false;
}

NumberStatus ParseFloat(std::string_view token, float& value) {
    const char* first = token.data();
    const char* last = first + token.size();
    // from_chars rejects a leading '+', which some exporters write.
    if (first != last && *first == '+') {
        ++first;
        if (first != last && *first == '-') return NumberStatus::kMalformed;
    }
    if (first == last) return NumberStatus::kMalformed;
    const auto [end, error] = std::from_chars(first, last, value);
    if (error == std::errc::result_out_of_range) {
        // Out of float range: tiny values flush towards zero, huge ones are errors.
        double wide = 0.0;
        const auto [wideEnd, wideError] = std::from_chars(first, last, wide);
        if (wideEnd != last) return NumberStatus::kMalformed;
        if (wideError == std::errc()) {
            if (std::fabs(wide) > double(FLT_MAX)) return NumberStatus::kOutOfRange;
            value = float(wide);
            return NumberStatus::kOk;
        }
        const std::string_view digits(first, size_t(last - first));
        const size_t exponent = digits.find_first_of("eE");
        if (exponent != std::string_view::npos && exponent + 1 < digits.size() &&
            digits[exponent + 1] == '-') {
            value = 0.0f;
            return NumberStatus::kOk;
        }
        return NumberStatus::kOutOfRange;
    }
    if (error != std::errc() || end != last) return NumberStatus::kMalformed;
    if (!std::isfinite(value)) return NumberStatus::kNonFinite;
    return NumberStatus::kOk;
}

}  // namespace rayclass::scene
