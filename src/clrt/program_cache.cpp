#include "rayclass/clrt/program_cache.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <system_error>

namespace rayclass::clrt {

namespace fs = std::filesystem;

namespace {

// Entry layout: kMagic, key size (u64), key, binary size (u64), binary, FNV-1a of the binary (u64).
constexpr char kMagic[8] = {'R', 'C', 'P', 'R', 'O', 'G', '1', '\n'};
constexpr const char* kSuffix = ".bin";
constexpr const char* kLockSuffix = ".lock";

uint64_t Fnv1a(const unsigned char* p, size_t n) {
    uint64_t h = 14695981039346656037ull;
    for (size_t i = 0; i < n; ++i) {
        h ^= p[i];
        h *= 1099511628211ull;
    }
    return h;
}

uint64_t Fnv1a(const std::string& s) {
    return Fnv1a(reinterpret_cast<const unsigned char*>(s.data()), s.size());
}

void PutU64(std::string& out, uint64_t v) {
    for (int i = 0; i < 8; ++i) out.push_back(char((v >> (8 * i)) & 0xFF));
}

bool GetU64(const std::string& in, size_t& at, uint64_t& v) {
    if (in.size() - at < 8) return false;
    v = 0;
    for (int i = 0; i < 8; ++i)
        v |= uint64_t(static_cast<unsigned char>(in[at + size_t(i)])) << (8 * i);
    at += 8;
    return true;
}

// The file's bytes in one read (an entry is megabytes: a character at a time is measurable in a
// small scene's start-up); empty when it cannot be read.
std::string ReadWhole(const fs::path& path) {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) return {};
    const std::streamoff size = in.tellg();
    if (size <= 0) return {};
    std::string data(size_t(size), '\0');
    in.seekg(0);
    if (!in.read(data.data(), size)) return {};
    return data;
}

}  // namespace

fs::path DefaultProgramCacheDir() {
    if (const char* dir = std::getenv("RAYCLASS_CACHE_DIR")) {
        if (std::strcmp(dir, "off") == 0 || *dir == '\0') return {};
        return fs::path(dir);
    }
    if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg == '/') {
        return fs::path(xdg) / "rayclass";
    }
    if (const char* home = std::getenv("HOME"); home && *home == '/') {
        return fs::path(home) / ".cache" / "rayclass";
    }
    return {};
}

fs::path ProgramCache::EntryPath(const std::string& key) const {
    char name[32];
    std::snprintf(name, sizeof name, "%016llx%s", static_cast<unsigned long long>(Fnv1a(key)),
                  kSuffix);
    return dir_ / name;
}

fs::path ProgramCache::LockPath(const std::string& key) const {
    fs::path path = EntryPath(key);
    path += kLockSuffix;
    return path;
}

ProgramCache::BuildLock& ProgramCache::BuildLock::operator=(BuildLock&& other) noexcept {
    if (this != &other) {
        if (fd_ >= 0) ::close(fd_);
        fd_ = std::exchange(other.fd_, -1);
    }
    return *this;
}

ProgramCache::BuildLock::~BuildLock() {
    if (fd_ >= 0) ::close(fd_);  // closing the file releases its lock
}

ProgramCache::BuildLock ProgramCache::LockBuild(const std::string& key) const {
    if (!Enabled()) return {};
    std::error_code ec;
    fs::create_directories(dir_, ec);
    if (ec) return {};
    const int fd = ::open(LockPath(key).c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) return {};
    int rc;
    do {
        rc = ::flock(fd, LOCK_EX);
    } while (rc != 0 && errno == EINTR);
    if (rc != 0) {
        ::close(fd);
        return {};
    }
    return BuildLock(fd);
}

std::vector<unsigned char> ProgramCache::Load(const std::string& key) const {
    if (!Enabled()) return {};
    const fs::path path = EntryPath(key);
    const std::string data = ReadWhole(path);
    if (data.size() < sizeof kMagic || std::memcmp(data.data(), kMagic, sizeof kMagic) != 0) {
        return {};
    }
    size_t at = sizeof kMagic;
    uint64_t keySize = 0, binSize = 0, sum = 0;
    if (!GetU64(data, at, keySize) || keySize != key.size() || data.size() - at < keySize ||
        data.compare(at, keySize, key) != 0) {
        return {};
    }
    at += keySize;
    if (!GetU64(data, at, binSize) || binSize == 0 || data.size() - at < binSize) return {};
    const auto* bin = reinterpret_cast<const unsigned char*>(data.data() + at);
    at += binSize;
    if (!GetU64(data, at, sum) || at != data.size() || sum != Fnv1a(bin, binSize)) return {};
    // A hit counts as a use, for Prune's choice of the least recently used.
    std::error_code ec;
    fs::last_write_time(path, fs::file_time_type::clock::now(), ec);
    return {bin, bin + binSize};
}

void ProgramCache::Store(const std::string& key, const std::vector<unsigned char>& binary) const {
    if (!Enabled() || binary.empty()) return;
    std::error_code ec;
    fs::create_directories(dir_, ec);
    if (ec) return;
    std::string data(kMagic, sizeof kMagic);
    PutU64(data, key.size());
    data += key;
    PutU64(data, binary.size());
    data.append(reinterpret_cast<const char*>(binary.data()), binary.size());
    PutU64(data, Fnv1a(binary.data(), binary.size()));

    static std::atomic<unsigned> counter{0};
    const fs::path path = EntryPath(key);
    char suffix[48];
    std::snprintf(suffix, sizeof suffix, ".%ld.%u.tmp", static_cast<long>(::getpid()), counter++);
    fs::path tmp = path;
    tmp += suffix;
    {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        out.write(data.data(), std::streamsize(data.size()));
        out.close();
        if (!out) {
            fs::remove(tmp, ec);
            return;
        }
    }
    fs::rename(tmp, path, ec);
    if (ec) {
        fs::remove(tmp, ec);
        return;
    }
    Prune();
}

void ProgramCache::Prune() const {
    std::error_code ec;
    std::vector<std::pair<fs::file_time_type, fs::path>> entries;
    const auto now = fs::file_time_type::clock::now();
    for (fs::directory_iterator it(dir_, ec), end; !ec && it != end; it.increment(ec)) {
        std::error_code timeEc;
        const auto t = it->last_write_time(timeEc);
        if (timeEc) continue;
        if (it->path().extension() == kSuffix) {
            entries.emplace_back(t, it->path());
        } else if ((it->path().extension() == ".tmp" || it->path().extension() == kLockSuffix) &&
                   now - t > std::chrono::hours(1)) {
            // Left by a process that died while storing, or by an old build: a lock file is
            // only needed while its entry is being built.
            std::error_code removeEc;
            fs::remove(it->path(), removeEc);
        }
    }
    if (entries.size() <= kMaxEntries) return;
    std::sort(entries.begin(), entries.end());
    for (size_t i = 0; i + kMaxEntries < entries.size(); ++i) fs::remove(entries[i].second, ec);
}

}  // namespace rayclass::clrt
