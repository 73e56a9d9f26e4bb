// Program binaries kept between processes. A build from source is slow on PoCL even when PoCL's
// own cache holds the result (it preprocesses the source with Clang to find its entry); a build
// from the binary skips that, a noticeable share of a small scene's render time.
// Entries are keyed by everything a binary depends on (platform, device, driver, options and the
// whole source), stored whole in the entry and compared on load, so a stale or colliding entry
// is never used; a damaged one is rebuilt from source.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace rayclass::clrt {

// $RAYCLASS_CACHE_DIR, else $XDG_CACHE_HOME/rayclass, else $HOME/.cache/rayclass; empty (no
// cache) when RAYCLASS_CACHE_DIR is "off" or no home is known.
std::filesystem::path DefaultProgramCacheDir();

class ProgramCache {
  public:
    // The newest entries kept: a store that finds more removes the least recently used.
    static constexpr size_t kMaxEntries = 64;

    // An empty dir turns the cache off.
    explicit ProgramCache(std::filesystem::path dir = {}) : dir_(std::move(dir)) {}

    const std::filesystem::path& Dir() const { return dir_; }
    bool Enabled() const { return !dir_.empty(); }

    // The binary stored under `key`, or empty when there is none, it is damaged or it was stored
    // under another key.
    std::vector<unsigned char> Load(const std::string& key) const;

    // Stores `binary` under `key`: written to a temporary file, then renamed, so a concurrent
    // Load sees the whole entry or none. Failures (a read-only directory, a full disk) are
    // ignored: the cache only saves time.
    void Store(const std::string& key, const std::vector<unsigned char>& binary) const;

    // The entry file for `key` (whether it exists or not).
    std::filesystem::path EntryPath(const std::string& key) const;

    // An exclusive lock on building `key`'s entry, held until it is destroyed: processes (or
    // threads) that miss the same entry at once take turns, so that the later ones find the
    // first one's binary instead of compiling it again. Not held (and no wait) when the cache is
    // off or the lock file cannot be made.
    class BuildLock {
      public:
        BuildLock() = default;
        explicit BuildLock(int fd) : fd_(fd) {}
        BuildLock(BuildLock&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
        BuildLock& operator=(BuildLock&& other) noexcept;
        BuildLock(const BuildLock&) = delete;
        BuildLock& operator=(const BuildLock&) = delete;
        ~BuildLock();

        bool Held() const { return fd_ >= 0; }

      private:
        int fd_ = -1;
    };
    [[nodiscard]] BuildLock LockBuild(const std::string& key) const;

    // The lock file of `key`'s entry.
    std::filesystem::path LockPath(const std::string& key) const;

  private:
    void Prune() const;

    std::filesystem::path dir_;
};

}  // namespace rayclass::clrt
