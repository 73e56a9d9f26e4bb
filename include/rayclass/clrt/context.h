// The OpenCL runtime layer: device selection, one context and in-order queue with profiling, and
// program builds from the kernel sources embedded in the binary. The C++ bindings' handles are
// reference-counted RAII objects; every failure becomes a rayclass::ClError carrying the error's
// name and, for builds, the build log.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "rayclass/clrt/opencl.h"
#include "rayclass/clrt/program_cache.h"

namespace rayclass::clrt {

// CL_INVALID_VALUE etc. for an OpenCL status code.
const char* ErrorName(int code);

struct DeviceInfo {
    int index = 0;  // position in the flat list over all platforms
    std::string platform;
    std::string name;
    std::string type;  // "cpu", "gpu", "accelerator", "other"
    std::string version;
    unsigned computeUnits = 0;
    unsigned long long globalMemBytes = 0;
    unsigned long long maxAllocBytes = 0;
};

// Every device of every platform; empty when no ICD is installed.
std::vector<DeviceInfo> ListDevices();

// Sets POCL_AFFINITY=1 (PoCL's CPU workers each kept on its own core) unless the caller set it,
// one worker runs, or the process may not use cores 0..n-1 for its n workers. It changes the
// environment: call it before other threads start. Every context calls it too, before PoCL
// starts its workers, where it changes nothing once the variable is set.
void PinPoclWorkers();

class Context {
  public:
    // spec: "" or "auto" (the first GPU, else the first CPU), "gpu", "cpu", or an index into
    // ListDevices(). Throws rayclass::Error when nothing matches.
    explicit Context(const std::string& spec = "auto");

    const cl::Context& context() const { return context_; }
    const cl::Device& device() const { return device_; }
    cl::CommandQueue& queue() { return queue_; }
    const DeviceInfo& info() const { return info_; }

    // Builds a program from embedded kernel files (names relative to cl/, e.g. "brute.cl"), in
    // order. `#include "x.h"` lines are resolved against cl/shared/ and each file keeps its name
    // in #line directives, so the build log points at the real file. The binary comes from the
    // program cache when it holds this source, options and device (then *fromCache is set),
    // else the build goes there; a build that finds another process building the same entry
    // waits for it and loads its binary.
    cl::Program BuildProgram(const std::vector<std::string>& files, const std::string& options = {},
                             bool* fromCache = nullptr) const;

    // What BuildProgram files the binary of `files` and `options` under in the program cache:
    // the platform, device and driver, the options and the assembled source.
    std::string ProgramKey(const std::vector<std::string>& files, const std::string& options) const;

    // The cache BuildProgram uses: DefaultProgramCacheDir() unless set here.
    const ProgramCache& programCache() const { return programCache_; }
    void SetProgramCache(ProgramCache cache) { programCache_ = std::move(cache); }

  private:
    std::optional<cl::Program> BuildFromCache(const std::string& key,
                                              const std::string& options) const;
    cl::Program BuildFromSource(const std::string& source, const std::vector<std::string>& files,
                                const std::string& options) const;

    cl::Device device_;
    cl::Context context_;
    cl::CommandQueue queue_;
    DeviceInfo info_;
    ProgramCache programCache_;
};

// The source text BuildProgram compiles (exposed for tests and for debugging build logs).
std::string AssembleProgramSource(const std::vector<std::string>& files);

// Rounds n up to a multiple of the fixed local size every kernel uses.
inline size_t RoundUp(size_t n, size_t local) { return (n + local - 1) / local * local; }

// Runs `call` and converts a cl::Error into a ClError naming the call and the error.
template <typename F>
decltype(auto) Check(const char* what, F&& call);

}  // namespace rayclass::clrt

#include "rayclass/core/error.h"

namespace rayclass::clrt {

template <typename F>
decltype(auto) Check(const char* what, F&& call) {
    try {
        return call();
    } catch (const cl::Error& e) {
        throw ClError(std::string(what) + ": " + e.what(), e.err(), ErrorName(e.err()));
    }
}

}  // namespace rayclass::clrt
