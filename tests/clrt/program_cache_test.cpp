// The program cache: entries come back only under their own key and whole, a build loads what an
// earlier build stored and its kernels compute the same, a damaged or refused binary is rebuilt
// from source, the cache stays bounded, and where it lives follows the environment.
#include "rayclass/clrt/program_cache.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include <array>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "clrt/device.h"
#include "rayclass/clrt/context.h"
#include "scene/test_files.h"

namespace rayclass::clrt {
namespace {

namespace fs = std::filesystem;
using scene::testing::TempDir;
using testing::kProbeOptions;

std::vector<unsigned char> Bytes(const std::string& s) { return {s.begin(), s.end()}; }

std::string ReadFile(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void WriteFile(const fs::path& p, const std::string& data) {
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(data.data(), std::streamsize(data.size()));
}

size_t CountEntries(const fs::path& dir) {
    size_t n = 0;
    for (const auto& e : fs::directory_iterator(dir)) n += e.path().extension() == ".bin";
    return n;
}

// Sets an environment variable for the test's scope (unset when `value` is null).
class ScopedEnv {
  public:
    ScopedEnv(const char* name, const char* value) : name_(name) {
        if (const char* old = std::getenv(name)) old_ = old;
        if (value) {
            setenv(name, value, 1);
        } else {
            unsetenv(name);
        }
    }
    ~ScopedEnv() {
        if (old_) {
            setenv(name_, old_->c_str(), 1);
        } else {
            unsetenv(name_);
        }
    }

  private:
    const char* name_;
    std::optional<std::string> old_;
};

TEST(ProgramCache, StoredBinaryComesBackOnlyUnderItsKey) {
    TempDir dir;
    const ProgramCache cache(dir.path() / "programs");  // created by the first store
    EXPECT_TRUE(cache.Load("key a").empty());
    cache.Store("key a", Bytes("binary a"));
    cache.Store("key b", Bytes("binary b"));
    EXPECT_EQ(cache.Load("key a"), Bytes("binary a"));
    EXPECT_EQ(cache.Load("key b"), Bytes("binary b"));
    EXPECT_TRUE(cache.Load("key c").empty());
    // A file under another key's name (as a hash collision would put it) is not that key's.
    fs::copy_file(cache.EntryPath("key a"), cache.EntryPath("key c"));
    EXPECT_TRUE(cache.Load("key c").empty());
    // A second store replaces the entry; no temporary file is left behind.
    cache.Store("key a", Bytes("binary a2"));
    EXPECT_EQ(cache.Load("key a"), Bytes("binary a2"));
    for (const auto& e : fs::directory_iterator(dir.path() / "programs")) {
        EXPECT_EQ(e.path().extension(), ".bin") << e.path();
    }
}

TEST(ProgramCache, DamagedEntriesAreIgnored) {
    TempDir dir;
    const ProgramCache cache(dir.path());
    cache.Store("key", Bytes("a binary of some length"));
    const fs::path entry = cache.EntryPath("key");
    const std::string whole = ReadFile(entry);
    ASSERT_EQ(cache.Load("key"), Bytes("a binary of some length"));
    // Cut anywhere, or one byte of the binary changed, or a byte appended.
    for (size_t cut : {size_t(0), size_t(5), size_t(20), whole.size() - 9, whole.size() - 1}) {
        WriteFile(entry, whole.substr(0, cut));
        EXPECT_TRUE(cache.Load("key").empty()) << "cut at " << cut;
    }
    std::string flipped = whole;
    flipped[whole.size() - 12] ^= 1;
    WriteFile(entry, flipped);
    EXPECT_TRUE(cache.Load("key").empty());
    WriteFile(entry, whole + "x");
    EXPECT_TRUE(cache.Load("key").empty());
    WriteFile(entry, whole);
    EXPECT_EQ(cache.Load("key"), Bytes("a binary of some length"));
}

TEST(ProgramCache, OffStoresNothingAndFailuresAreSilent) {
    const ProgramCache off;
    EXPECT_FALSE(off.Enabled());
    off.Store("key", Bytes("binary"));
    EXPECT_TRUE(off.Load("key").empty());
    // A directory that cannot be made (a file is in the way): stores are dropped, no throw.
    TempDir dir;
    dir.Write("file", "not a directory");
    const ProgramCache blocked(dir.path() / "file" / "programs");
    EXPECT_NO_THROW(blocked.Store("key", Bytes("binary")));
    EXPECT_TRUE(blocked.Load("key").empty());
}

TEST(ProgramCache, KeepsTheMostRecentlyUsedEntries) {
    TempDir dir;
    const ProgramCache cache(dir.path());
    const size_t n = ProgramCache::kMaxEntries;
    const auto now = fs::file_time_type::clock::now();
    for (size_t i = 0; i < n; ++i) {
        const std::string key = "key " + std::to_string(i);
        cache.Store(key, Bytes("binary " + std::to_string(i)));
        // Entry i was last used i minutes after entry 0 (one second apart would do, but file
        // systems with coarse times exist).
        fs::last_write_time(cache.EntryPath(key),
                            now - std::chrono::hours(2) + std::chrono::minutes(i));
    }
    ASSERT_EQ(CountEntries(dir.path()), n);
    // A load is a use: entry 0 becomes the newest, so entries 1 and 2 go first.
    EXPECT_FALSE(cache.Load("key 0").empty());
    // A temporary file of a process that died while storing, two hours ago.
    const fs::path stale = dir.Write("0123456789abcdef.bin.99.0.tmp", "half an entry");
    fs::last_write_time(stale, now - std::chrono::hours(2));
    cache.Store("new 1", Bytes("binary"));
    cache.Store("new 2", Bytes("binary"));
    EXPECT_EQ(CountEntries(dir.path()), n);
    EXPECT_FALSE(fs::exists(stale));
    EXPECT_FALSE(cache.Load("key 0").empty());
    EXPECT_TRUE(cache.Load("key 1").empty());
    EXPECT_TRUE(cache.Load("key 2").empty());
    EXPECT_FALSE(cache.Load("key 3").empty());
    EXPECT_FALSE(cache.Load("new 1").empty());
    EXPECT_FALSE(cache.Load("new 2").empty());
}

TEST(ProgramCache, DefaultDirectoryFollowsTheEnvironment) {
    ScopedEnv xdg("XDG_CACHE_HOME", "/xdg/cache");
    ScopedEnv home("HOME", "/home/someone");
    {
        ScopedEnv dir("RAYCLASS_CACHE_DIR", "/somewhere/else");
        EXPECT_EQ(DefaultProgramCacheDir(), fs::path("/somewhere/else"));
    }
    {
        ScopedEnv dir("RAYCLASS_CACHE_DIR", "off");
        EXPECT_EQ(DefaultProgramCacheDir(), fs::path());
    }
    {
        ScopedEnv dir("RAYCLASS_CACHE_DIR", "");
        EXPECT_EQ(DefaultProgramCacheDir(), fs::path());
    }
    ScopedEnv unset("RAYCLASS_CACHE_DIR", nullptr);
    EXPECT_EQ(DefaultProgramCacheDir(), fs::path("/xdg/cache/rayclass"));
    {
        // The XDG specification ignores relative paths.
        ScopedEnv relative("XDG_CACHE_HOME", "relative/cache");
        EXPECT_EQ(DefaultProgramCacheDir(), fs::path("/home/someone/.cache/rayclass"));
    }
    ScopedEnv noXdg("XDG_CACHE_HOME", nullptr);
    EXPECT_EQ(DefaultProgramCacheDir(), fs::path("/home/someone/.cache/rayclass"));
    ScopedEnv noHome("HOME", nullptr);
    EXPECT_EQ(DefaultProgramCacheDir(), fs::path());
}

// Whether another open file description can take `path`'s lock now (the kernel's answer, not
// the cache's).
bool LockIsFree(const fs::path& path) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) return false;
    const bool free = ::flock(fd, LOCK_EX | LOCK_NB) == 0;
    ::close(fd);
    return free;
}

TEST(ProgramCache, BuildLockIsExclusiveUntilReleased) {
    TempDir dir;
    const ProgramCache cache(dir.path() / "programs");
    {
        ProgramCache::BuildLock lock = cache.LockBuild("key a");
        ASSERT_TRUE(lock.Held());
        EXPECT_FALSE(LockIsFree(cache.LockPath("key a")));
        EXPECT_TRUE(LockIsFree(cache.LockPath("key b")));  // another entry builds meanwhile
        ProgramCache::BuildLock moved = std::move(lock);
        EXPECT_TRUE(moved.Held());
        EXPECT_FALSE(LockIsFree(cache.LockPath("key a")));
    }
    EXPECT_TRUE(LockIsFree(cache.LockPath("key a")));
    EXPECT_FALSE(ProgramCache().LockBuild("key a").Held());  // cache off: nothing to wait for
}

// The layout probe's output, which depends on nothing but the compiled program.
std::vector<uint32_t> RunProbe(Context& ctx, const cl::Program& program) {
    cl::Kernel kernel(program, "rc_layout_probe");
    cl::Buffer out(ctx.context(), CL_MEM_WRITE_ONLY, 1024 * sizeof(uint32_t));
    kernel.setArg(0, out);
    ctx.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(1));
    std::vector<uint32_t> v(1024);
    ctx.queue().enqueueReadBuffer(out, CL_TRUE, 0, v.size() * sizeof(uint32_t), v.data());
    v.resize(v[0] + 1);
    return v;
}

TEST(ProgramCache, SecondBuildLoadsTheFirstOnesBinary) {
    TempDir dir;
    Context ctx(TestDeviceSpec());
    ctx.SetProgramCache(ProgramCache(dir.path()));
    bool fromCache = true;
    const std::vector<uint32_t> fromSource =
        RunProbe(ctx, ctx.BuildProgram({"layout_probe.cl"}, kProbeOptions, &fromCache));
    EXPECT_FALSE(fromCache);
    ASSERT_EQ(CountEntries(dir.path()), 1u);
    EXPECT_TRUE(fs::exists(
        ctx.programCache().EntryPath(ctx.ProgramKey({"layout_probe.cl"}, kProbeOptions))));
    EXPECT_EQ(RunProbe(ctx, ctx.BuildProgram({"layout_probe.cl"}, kProbeOptions, &fromCache)),
              fromSource);
    EXPECT_TRUE(fromCache);
    // Other options are another program.
    const std::string other = std::string(kProbeOptions) + " -DRC_UNUSED_MACRO=1";
    EXPECT_NE(ctx.ProgramKey({"layout_probe.cl"}, other),
              ctx.ProgramKey({"layout_probe.cl"}, kProbeOptions));
    EXPECT_EQ(RunProbe(ctx, ctx.BuildProgram({"layout_probe.cl"}, other, &fromCache)), fromSource);
    EXPECT_FALSE(fromCache);
    EXPECT_EQ(CountEntries(dir.path()), 2u);
    // A failed build stores nothing.
    EXPECT_THROW(ctx.BuildProgram({"brute.cl"}, "-cl-std=CL1.2 -DRC_LOCAL_SIZE="), ClError);
    EXPECT_EQ(CountEntries(dir.path()), 2u);
}

TEST(ProgramCache, BinaryTheDriverRefusesIsRebuiltFromSource) {
    TempDir dir;
    Context ctx(TestDeviceSpec());
    ctx.SetProgramCache(ProgramCache(dir.path()));
    const std::string key = ctx.ProgramKey({"layout_probe.cl"}, kProbeOptions);
    // A whole, well-formed entry whose binary is no program.
    ctx.programCache().Store(key, Bytes("this is not a program binary"));
    bool fromCache = true;
    const std::vector<uint32_t> probe =
        RunProbe(ctx, ctx.BuildProgram({"layout_probe.cl"}, kProbeOptions, &fromCache));
    EXPECT_FALSE(fromCache);
    EXPECT_GT(probe[0], 0u);
    // The entry now holds the real binary.
    EXPECT_NE(ctx.programCache().Load(key), Bytes("this is not a program binary"));
    EXPECT_EQ(RunProbe(ctx, ctx.BuildProgram({"layout_probe.cl"}, kProbeOptions, &fromCache)),
              probe);
    EXPECT_TRUE(fromCache);
}

// Builds of one program that start together compile it once: the others wait for the entry.
TEST(ProgramCache, ConcurrentBuildsOfOneProgramCompileItOnce) {
    TempDir dir;
    std::array<bool, 2> fromCache{true, true};
    std::array<std::vector<uint32_t>, 2> probe;
    // The contexts are made first: the ICD loader's first platform query is not thread-safe.
    std::array<std::optional<Context>, 2> ctx;
    for (auto& c : ctx) {
        c.emplace(TestDeviceSpec());
        c->SetProgramCache(ProgramCache(dir.path()));
    }
    std::vector<std::thread> builders;
    for (size_t i = 0; i < 2; ++i) {
        builders.emplace_back([&, i] {
            probe[i] = RunProbe(
                *ctx[i], ctx[i]->BuildProgram({"layout_probe.cl"}, kProbeOptions, &fromCache[i]));
        });
    }
    for (auto& t : builders) t.join();
    EXPECT_NE(fromCache[0], fromCache[1]);
    EXPECT_EQ(probe[0], probe[1]);
    EXPECT_EQ(CountEntries(dir.path()), 1u);
}

TEST(ProgramCache, OffBuildsFromSourceEveryTime) {
    Context ctx(TestDeviceSpec());
    ctx.SetProgramCache(ProgramCache());
    bool fromCache = true;
    ctx.BuildProgram({"layout_probe.cl"}, kProbeOptions, &fromCache);
    EXPECT_FALSE(fromCache);
    ctx.BuildProgram({"layout_probe.cl"}, kProbeOptions, &fromCache);
    EXPECT_FALSE(fromCache);
}

}  // namespace
}  // namespace rayclass::clrt
