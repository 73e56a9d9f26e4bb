// Small helpers every query and the renderer use to build their program, move data and launch
// kernels: one fixed local size (PoCL compiles a work-group function per local size), buffers
// that reject nothing (OpenCL refuses zero-sized ones), and per-kernel device time.
#pragma once

#include <algorithm>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "rayclass/clrt/context.h"

namespace rayclass::render {

// Work-items per work-group in every kernel launch (the kernels' reqd_work_group_size).
constexpr size_t kLocalSize = 64;

// A program of the kernel files `files` (clrt::Context::BuildProgram's, *fromCache too) with the
// options every kernel needs and `extraOptions`.
cl::Program BuildProgramFiles(const clrt::Context& ctx, const std::vector<std::string>& files,
                              const std::string& extraOptions, bool* fromCache = nullptr);

// The kernel files of a render program: ray generation, shading and compaction first, then
// `queryFiles` (the ray queries' kernels), the Newton statistics of --stats last.
std::vector<std::string> RenderProgramFiles(const std::vector<std::string>& queryFiles);

// The program holding every kernel the renderer uses, with the options they need, and the scalar
// shading kernel the tests hold the renderer's to (cl/shade_scalar.cl) (*fromCache: see
// clrt::Context::BuildProgram).
cl::Program BuildRenderProgram(const clrt::Context& ctx, const std::string& extraOptions = {},
                               bool* fromCache = nullptr);

// Sums the device time of every launch per kernel name.
class KernelTimer {
  public:
    void Record(const std::string& kernel, const cl::Event& event);
    const std::map<std::string, double>& Seconds() const { return seconds_; }

  private:
    std::map<std::string, double> seconds_;
};

// A read-only buffer over `bytes` of host memory at `data`, which must outlive it unchanged: the
// device may use that memory in place (PoCL on a CPU does) rather than a copy.
inline cl::Buffer HostMemoryBuffer(clrt::Context& ctx, const void* data, size_t bytes) {
    return clrt::Check("clCreateBuffer", [&] {
        return cl::Buffer(ctx.context(), CL_MEM_READ_ONLY | CL_MEM_USE_HOST_PTR, bytes,
                          const_cast<void*>(data));
    });
}

// A read-only buffer holding a copy of `v` (one zeroed element when `v` is empty).
template <typename T>
cl::Buffer UploadVector(clrt::Context& ctx, const std::vector<T>& v) {
    const std::vector<T> one(1);
    const std::vector<T>& data = v.empty() ? one : v;
    return clrt::Check("clCreateBuffer", [&] {
        return cl::Buffer(ctx.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR,
                          data.size() * sizeof(T), const_cast<T*>(data.data()));
    });
}

// A read-only buffer of `v`, which must outlive it unchanged: on a CPU device a buffer over `v`'s
// own memory, which PoCL reads in place (a copy would fault in the pages of a second one),
// elsewhere UploadVector's copy.
template <typename T>
cl::Buffer ReadOnlyView(clrt::Context& ctx, const std::vector<T>& v) {
    if (ctx.info().type != "cpu" || v.empty()) return UploadVector(ctx, v);
    return HostMemoryBuffer(ctx, v.data(), v.size() * sizeof(T));
}

// A buffer of at least one byte (read-write unless `flags` say otherwise). On a CPU device a
// large one lies in host memory of its own (core/large_pages.h), which the device uses in place
// and which goes with the buffer.
cl::Buffer DeviceBuffer(clrt::Context& ctx, size_t bytes, cl_mem_flags flags = CL_MEM_READ_WRITE);

// Faults in the first `bytes` of a DeviceBuffer made over host memory of its own, so that the
// kernel that first writes them need not (nothing where the device allocated the buffer).
void PopulateDeviceBuffer(const cl::Buffer& buffer, size_t bytes);

// Rays per batch: `requested`, at most the image's rays, and few enough that the largest buffer
// a batch needs per ray (its shadow rays, one per light, or its two secondary rays and their
// records) fits one allocation of the device. At least one.
size_t BatchRays(size_t requested, size_t imageRays, uint32_t nLights, uint64_t maxAllocBytes);

template <typename... Args>
void SetArgs(cl::Kernel& kernel, const Args&... args) {
    clrt::Check("clSetKernelArg", [&] {
        cl_uint i = 0;
        (kernel.setArg(i++, args), ...);
    });
}

// Runs `kernel` over n work-items (rounded up to the local size; kernels bounds-check) and adds
// its device time to `timer`.
void Launch(clrt::Context& ctx, cl::Kernel& kernel, size_t n, KernelTimer& timer);

// Rays a work-item of the 16-lane kernels (RC_PACKET in cl/bvh.cl, rc_shade16_ids), and the
// work-items they take for n rays.
constexpr uint32_t kPacketRays = 16;
constexpr size_t PacketItems(size_t n) { return (n + kPacketRays - 1) / kPacketRays; }

// Reads n uint32 counters back and sums them (`scratch` is reused host memory).
uint64_t SumCounters(clrt::Context& ctx, const cl::Buffer& counters, uint32_t n,
                     std::vector<uint32_t>& scratch);

// A device buffer that grows to the largest size asked for and is reused after that.
class GrowingBuffer {
  public:
    const cl::Buffer& Reserve(clrt::Context& ctx, size_t bytes);
    // Reserves room for `data` and enqueues a non-blocking copy of it (keep `data` alive and
    // unchanged until the queue has passed the copy).
    template <typename T, typename Allocator>
    const cl::Buffer& Upload(clrt::Context& ctx, const std::vector<T, Allocator>& data) {
        Reserve(ctx, data.size() * sizeof(T));
        if (!data.empty()) {
            clrt::Check("clEnqueueWriteBuffer", [&] {
                ctx.queue().enqueueWriteBuffer(buffer_, CL_FALSE, 0, data.size() * sizeof(T),
                                               data.data());
            });
        }
        return buffer_;
    }

    // The same for arrays that stay unchanged until the kernels that read them have finished:
    // on a CPU device a buffer over `data` itself, which PoCL reads in place (a copy of a deep
    // generation's leaf lists is large, and faults in the pages of a second copy of them).
    template <typename T, typename Allocator>
    const cl::Buffer& Share(clrt::Context& ctx, const std::vector<T, Allocator>& data) {
        if (ctx.info().type != "cpu" || data.empty()) return Upload(ctx, data);
        buffer_ = HostMemoryBuffer(ctx, data.data(), data.size() * sizeof(T));
        capacity_ = 0;  // not ours to write: Reserve makes a buffer again
        return buffer_;
    }

  private:
    cl::Buffer buffer_;
    size_t capacity_ = 0;
};

}  // namespace rayclass::render
