#include "rayclass/clrt/context.h"

#include <sched.h>
#include <unistd.h>

#include <cctype>
#include <cstdlib>
#include <map>
#include <set>
#include <string>
#include <string_view>

namespace rayclass::clrt {

const std::map<std::string, std::string>& EmbeddedKernelSources();

namespace {

std::string TypeName(cl_device_type type) {
    if (type & CL_DEVICE_TYPE_GPU) return "gpu";
    if (type & CL_DEVICE_TYPE_CPU) return "cpu";
    if (type & CL_DEVICE_TYPE_ACCELERATOR) return "accelerator";
    return "other";
}

struct Found {
    cl::Device device;
    DeviceInfo info;
};

std::vector<Found> AllDevices() {
    PinPoclWorkers();
    std::vector<cl::Platform> platforms;
    // An ICD loader with no platform reports CL_PLATFORM_NOT_FOUND_KHR: that is "no devices".
    try {
        cl::Platform::get(&platforms);
    } catch (const cl::Error&) {
        return {};
    }
    std::vector<Found> found;
    for (const auto& platform : platforms) {
        std::vector<cl::Device> devices;
        try {
            platform.getDevices(CL_DEVICE_TYPE_ALL, &devices);
        } catch (const cl::Error&) {
            continue;
        }
        for (const auto& d : devices) {
            DeviceInfo info;
            info.index = int(found.size());
            info.platform = platform.getInfo<CL_PLATFORM_NAME>();
            info.name = d.getInfo<CL_DEVICE_NAME>();
            info.type = TypeName(d.getInfo<CL_DEVICE_TYPE>());
            info.version = d.getInfo<CL_DEVICE_VERSION>();
            info.computeUnits = d.getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>();
            info.globalMemBytes = d.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
            info.maxAllocBytes = d.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
            found.push_back({d, info});
        }
    }
    return found;
}

// `s` without its leading white space.
std::string_view TrimFront(std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    return s;
}

// The file a line `#include "name"` names (white space allowed around its tokens), else empty.
// Parsed by hand: std::regex over every line was slow enough to show in the device's start.
std::string_view IncludedFile(std::string_view line) {
    line = TrimFront(line);
    if (!line.starts_with('#')) return {};
    line = TrimFront(line.substr(1));
    if (!line.starts_with("include")) return {};
    line = TrimFront(line.substr(std::string_view("include").size()));
    if (!line.starts_with('"')) return {};
    line.remove_prefix(1);
    const size_t close = line.find('"');
    if (close == std::string_view::npos || !TrimFront(line.substr(close + 1)).empty()) return {};
    return line.substr(0, close);
}

// Whether a file is appended at each of its includes: code written once for several
// instantiations, each include under other macros (cl/bvh_packet.inc.cl, one per lane width).
// Every other file is appended at its first include only, as if guarded.
bool IncludedEachTime(std::string_view name) { return name.ends_with(".inc.cl"); }

void AppendFile(const std::string& name, const std::string& sharedPrefix,
                std::set<std::string>& included, std::string& out) {
    const auto& sources = EmbeddedKernelSources();
    auto it = sources.find(name);
    if (it == sources.end()) throw Error("kernel source '" + name + "' is not embedded");
    if (!included.insert(name).second && !IncludedEachTime(name)) return;
    out += "#line 1 \"" + name + "\"\n";
    std::string_view text = it->second;
    for (int lineNo = 1; !text.empty(); ++lineNo) {
        const size_t end = text.find('\n');
        const std::string_view line = text.substr(0, end);
        text.remove_prefix(end == std::string_view::npos ? text.size() : end + 1);
        if (const std::string_view file = IncludedFile(line); !file.empty()) {
            std::string target(file);
            if (!sources.count(target)) target = sharedPrefix + target;
            AppendFile(target, sharedPrefix, included, out);
            out += "#line " + std::to_string(lineNo + 1) + " \"" + name + "\"\n";
        } else {
            out += line;
            out += '\n';
        }
    }
}

}  // namespace

// PoCL's pthread device wakes its sleeping workers where the kernel's scheduler places them,
// often all on the core the host thread holds, while the other cores wait for the load balancer
// (milliseconds: a short kernel's whole run). POCL_AFFINITY keeps worker i on core i, which
// fails where the process may not use core i (a cpuset, taskset, a batch system's share): newer
// PoCL releases abort there, so the workers stay free unless cores 0..n-1 are all the process's.
void PinPoclWorkers() {
#ifdef __linux__
    if (std::getenv("POCL_AFFINITY") != nullptr) return;
    const char* count = std::getenv("POCL_MAX_PTHREAD_COUNT");
    const long online = sysconf(_SC_NPROCESSORS_ONLN);
    const long workers = count != nullptr ? std::atol(count) : online;
    if (workers <= 1 || workers > CPU_SETSIZE) return;
    cpu_set_t allowed;
    if (sched_getaffinity(0, sizeof(allowed), &allowed) != 0) return;
    for (long core = 0; core < workers; ++core) {
        if (!CPU_ISSET(core, &allowed)) return;
    }
    setenv("POCL_AFFINITY", "1", 0);
#endif
}

std::vector<DeviceInfo> ListDevices() {
    std::vector<DeviceInfo> infos;
    for (auto& f : AllDevices()) infos.push_back(f.info);
    return infos;
}

Context::Context(const std::string& spec) {
    auto all = AllDevices();
    if (all.empty()) {
        throw Error(
            "no OpenCL device found (is an ICD such as pocl-opencl-icd installed? run "
            "scripts/setup)");
    }
    const Found* chosen = nullptr;
    auto firstOf = [&](const std::string& type) -> const Found* {
        for (const auto& f : all)
            if (f.info.type == type) return &f;
        return nullptr;
    };
    if (spec.empty() || spec == "auto") {
        chosen = firstOf("gpu");
        if (!chosen) chosen = firstOf("cpu");
        if (!chosen) chosen = &all.front();
    } else if (spec == "gpu" || spec == "cpu") {
        chosen = firstOf(spec);
        if (!chosen) throw Error("no OpenCL " + spec + " device found (see 'rayclass devices')");
    } else {
        size_t pos = 0;
        int index = -1;
        try {
            index = std::stoi(spec, &pos);
        } catch (const std::exception&) {
            pos = 0;
        }
        if (pos != spec.size() || index < 0) {
            throw Error("--device must be cpu, gpu, auto or a device index, not '" + spec + "'");
        }
        if (index >= int(all.size())) {
            throw Error("device index " + spec + " out of range (" + std::to_string(all.size()) +
                        " devices; see 'rayclass devices')");
        }
        chosen = &all[size_t(index)];
    }
    device_ = chosen->device;
    info_ = chosen->info;
    programCache_ = ProgramCache(DefaultProgramCacheDir());
    Check("clCreateContext", [&] { context_ = cl::Context(device_); });
    Check("clCreateCommandQueue",
          [&] { queue_ = cl::CommandQueue(context_, device_, cl::QueueProperties::Profiling); });
}

std::string AssembleProgramSource(const std::vector<std::string>& files) {
    std::string out;
    std::set<std::string> included;
    for (const auto& f : files) AppendFile(f, "shared/", included, out);
    return out;
}

namespace {

// The key of ProgramKey for an assembled source.
std::string KeyOf(const cl::Device& device, const std::string& options, const std::string& source) {
    const cl::Platform platform(device.getInfo<CL_DEVICE_PLATFORM>());
    std::string key;
    for (const std::string& part :
         {platform.getInfo<CL_PLATFORM_NAME>(), platform.getInfo<CL_PLATFORM_VERSION>(),
          device.getInfo<CL_DEVICE_VENDOR>(), device.getInfo<CL_DEVICE_NAME>(),
          device.getInfo<CL_DEVICE_VERSION>(), device.getInfo<CL_DRIVER_VERSION>(),
          "options: " + options}) {
        key += part;
        key += '\n';
    }
    return key + source;
}

}  // namespace

std::string Context::ProgramKey(const std::vector<std::string>& files,
                                const std::string& options) const {
    return Check("clGetDeviceInfo",
                 [&] { return KeyOf(device_, options, AssembleProgramSource(files)); });
}

cl::Program Context::BuildProgram(const std::vector<std::string>& files, const std::string& options,
                                  bool* fromCache) const {
    const std::string source = AssembleProgramSource(files);
    if (fromCache) *fromCache = false;
    if (!programCache_.Enabled()) return BuildFromSource(source, files, options);
    const std::string key =
        Check("clGetDeviceInfo", [&] { return KeyOf(device_, options, source); });
    if (auto program = BuildFromCache(key, options)) {
        if (fromCache) *fromCache = true;
        return *program;
    }
    // Another process may be building the same entry: wait for it, then look again.
    const ProgramCache::BuildLock lock = programCache_.LockBuild(key);
    if (lock.Held()) {
        if (auto program = BuildFromCache(key, options)) {
            if (fromCache) *fromCache = true;
            return *program;
        }
    }
    cl::Program program = BuildFromSource(source, files, options);
    try {
        const auto binaries = program.getInfo<CL_PROGRAM_BINARIES>();
        if (binaries.size() == 1) programCache_.Store(key, binaries[0]);
    } catch (const cl::Error&) {
        // A device that gives no binary simply builds from source every time.
    }
    return program;
}

std::optional<cl::Program> Context::BuildFromCache(const std::string& key,
                                                   const std::string& options) const {
    const std::vector<unsigned char> binary = programCache_.Load(key);
    if (binary.empty()) return std::nullopt;
    try {
        cl::Program program(context_, std::vector<cl::Device>{device_},
                            cl::Program::Binaries{binary});
        program.build(std::vector<cl::Device>{device_}, options.c_str());
        return program;
    } catch (const cl::Error&) {
        return std::nullopt;  // a binary the driver no longer takes: rebuilt from source
    }
}

cl::Program Context::BuildFromSource(const std::string& source,
                                     const std::vector<std::string>& files,
                                     const std::string& options) const {
    cl::Program program =
        Check("clCreateProgramWithSource", [&] { return cl::Program(context_, source); });
    try {
        program.build(std::vector<cl::Device>{device_}, options.c_str());
    } catch (const cl::BuildError& e) {
        std::string log;
        for (const auto& [dev, text] : e.getBuildLog()) log += text;
        std::string names;
        for (const auto& f : files) names += (names.empty() ? "" : ", ") + f;
        throw ClError("building OpenCL program (" + names + ") with options '" + options + "'",
                      e.err(), ErrorName(e.err()), "build log:\n" + log);
    } catch (const cl::Error& e) {
        throw ClError("clBuildProgram", e.err(), ErrorName(e.err()));
    }
    return program;
}

}  // namespace rayclass::clrt
