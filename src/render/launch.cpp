#include "rayclass/render/launch.h"

#include <algorithm>
#include <numeric>

namespace rayclass::render {

cl::Buffer DeviceBuffer(clrt::Context& ctx, size_t bytes) {
    return clrt::Check("clCreateBuffer", [&] {
        return cl::Buffer(ctx.context(), CL_MEM_READ_WRITE, std::max<size_t>(1, bytes));
    });
}

size_t BatchRays(size_t requested, size_t imageRays, uint32_t nLights, uint64_t maxAllocBytes) {
    const uint64_t perRay = std::max<uint64_t>(
        {uint64_t(nLights) * sizeof(RcRay), 2 * sizeof(RcRay), 2 * sizeof(RcRayInfo)});
    const uint64_t fits = maxAllocBytes / perRay;
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
