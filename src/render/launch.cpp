#include "rayclass/render/launch.h"

#include <algorithm>
#include <memory>
#include <numeric>

#include "rayclass/core/large_pages.h"
#include "rc_types.h"

namespace rayclass::render {

namespace {

// Memory of AllocateLarge's, freed with its owner.
class LargePages {
  public:
    explicit LargePages(size_t bytes) : p_(AllocateLarge(bytes)), bytes_(bytes) {}
    ~LargePages() { FreeLarge(p_, bytes_); }
    LargePages(const LargePages&) = delete;
    LargePages& operator=(const LargePages&) = delete;
    void* data() const { return p_; }

  private:
    void* p_;
    size_t bytes_;
};

void CL_CALLBACK FreePages(cl_mem, void* pages) { delete static_cast<LargePages*>(pages); }

}  // namespace

cl::Program BuildProgramFiles(const clrt::Context& ctx, const std::vector<std::string>& files,
                              const std::string& extraOptions, bool* fromCache) {
    const std::string options = "-cl-std=CL1.2 -DRC_LOCAL_SIZE=" + std::to_string(kLocalSize) +
                                (extraOptions.empty() ? "" : " " + extraOptions);
    return ctx.BuildProgram(files, options, fromCache);
}

std::vector<std::string> RenderProgramFiles(const std::vector<std::string>& queryFiles) {
    std::vector<std::string> files = {"camera.cl", "intersect.cl", "encoding.cl",
                                      "shade.cl",  "shade16.cl",   "generation.cl"};
    files.insert(files.end(), queryFiles.begin(), queryFiles.end());
    files.push_back("patch_stats.cl");
    return files;
}

cl::Program BuildRenderProgram(const clrt::Context& ctx, const std::string& extraOptions,
                               bool* fromCache) {
    std::vector<std::string> files =
        RenderProgramFiles({"brute.cl", "classified.cl", "classified_vertex.cl",
                            "classified_scalar.cl", "bvh.cl", "kdtree.cl", "grid.cl", "cones.cl"});
    files.push_back("shade_scalar.cl");
    return BuildProgramFiles(ctx, files, extraOptions, fromCache);
}

void KernelTimer::Record(const std::string& kernel, const cl::Event& event) {
    event.wait();
    const auto start = event.getProfilingInfo<CL_PROFILING_COMMAND_START>();
    const auto end = event.getProfilingInfo<CL_PROFILING_COMMAND_END>();
    seconds_[kernel] += double(end - start) * 1e-9;
}

cl::Buffer DeviceBuffer(clrt::Context& ctx, size_t bytes, cl_mem_flags flags) {
    bytes = std::max<size_t>(1, bytes);
    if (ctx.info().type != "cpu" || bytes < kLargeAllocationBytes) {
        return clrt::Check("clCreateBuffer",
                           [&] { return cl::Buffer(ctx.context(), flags, bytes); });
    }
    // Over memory of our own the device works in place, and the buffer frees it when it goes.
    // (Declared before the buffer: should the callback fail, the buffer goes first.)
    auto pages = std::make_unique<LargePages>(bytes);
    cl::Buffer buffer = clrt::Check("clCreateBuffer", [&] {
        return cl::Buffer(ctx.context(), (flags & ~CL_MEM_ALLOC_HOST_PTR) | CL_MEM_USE_HOST_PTR,
                          bytes, pages->data());
    });
    clrt::Check("clSetMemObjectDestructorCallback",
                [&] { buffer.setDestructorCallback(FreePages, pages.get()); });
    pages.release();  // the buffer's now
    return buffer;
}

void PopulateDeviceBuffer(const cl::Buffer& buffer, size_t bytes) {
    if (!(buffer.getInfo<CL_MEM_FLAGS>() & CL_MEM_USE_HOST_PTR)) return;
    PopulateLarge(buffer.getInfo<CL_MEM_HOST_PTR>(),
                  std::min(bytes, buffer.getInfo<CL_MEM_SIZE>()));
}

size_t BatchRays(size_t requested, size_t imageRays, uint32_t nLights, uint64_t maxAllocBytes) {
    const uint64_t perRay = std::max<uint64_t>(
        {uint64_t(nLights) * sizeof(RcRay), 2 * sizeof(RcRay), 2 * sizeof(RcRayInfo)});
    // Whole runs of secondary slots (RC_SECONDARY_SLOT), so that they too fit.
    uint64_t fits = maxAllocBytes / perRay;
    if (fits >= RC_SECONDARY_RUN) fits -= fits % RC_SECONDARY_RUN;
    return size_t(std::max<uint64_t>(1, std::min<uint64_t>({requested, imageRays, fits})));
}

void Launch(clrt::Context& ctx, cl::Kernel& kernel, size_t n, KernelTimer& timer) {
    if (n == 0) return;
    cl::Event event;
    clrt::Check("clEnqueueNDRangeKernel", [&] {
        ctx.queue().enqueueNDRangeKernel(kernel, cl::NullRange,
                                         cl::NDRange(clrt::RoundUp(n, kLocalSize)),
                                         cl::NDRange(kLocalSize), nullptr, &event);
    });
    timer.Record(kernel.getInfo<CL_KERNEL_FUNCTION_NAME>(), event);
}

uint64_t SumCounters(clrt::Context& ctx, const cl::Buffer& counters, uint32_t n,
                     std::vector<uint32_t>& scratch) {
    if (n == 0) return 0;
    scratch.resize(n);
    clrt::Check("clEnqueueReadBuffer", [&] {
        ctx.queue().enqueueReadBuffer(counters, CL_TRUE, 0, n * sizeof(uint32_t), scratch.data());
    });
    return std::accumulate(scratch.begin(), scratch.end(), uint64_t(0));
}

const cl::Buffer& GrowingBuffer::Reserve(clrt::Context& ctx, size_t bytes) {
    if (bytes > capacity_ || capacity_ == 0) {
        capacity_ = std::max<size_t>(bytes + bytes / 4, 64);
        buffer_ = DeviceBuffer(ctx, capacity_);
    }
    return buffer_;
}

}  // namespace rayclass::render
