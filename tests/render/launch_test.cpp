// DeviceBuffer on PoCL's CPU device: a large buffer lies in host memory of its own, which the
// device reads and writes in place and which goes when the buffer does; a small one is the
// device's own.
#include "rayclass/render/launch.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <numeric>
#include <vector>

#include "core/mapped.h"
#include "rayclass/core/large_pages.h"

namespace rayclass::render {
namespace {

clrt::Context& Ctx() {
    static clrt::Context ctx("cpu");
    return ctx;
}

using rayclass::testing::Mapped;

TEST(DeviceBuffer, LargeOnesLieInPagesOfTheirOwnAndGoWithTheBuffer) {
    clrt::Context& ctx = Ctx();
    ASSERT_EQ(ctx.info().type, "cpu");
    const size_t n = kLargeAllocationBytes / 4 + 3;
    std::vector<uint32_t> data(n);
    std::iota(data.begin(), data.end(), 0u);
    void* at = nullptr;
    {
        cl::Buffer buffer = DeviceBuffer(ctx, n * 4);
        ctx.queue().enqueueWriteBuffer(buffer, CL_TRUE, 0, n * 4, data.data());
        at = ctx.queue().enqueueMapBuffer(buffer, CL_TRUE, CL_MAP_READ, 0, n * 4);
        EXPECT_NE(buffer.getInfo<CL_MEM_FLAGS>() & CL_MEM_USE_HOST_PTR, 0u);
        EXPECT_EQ(reinterpret_cast<uintptr_t>(at) % uintptr_t(sysconf(_SC_PAGESIZE)), 0u);
        EXPECT_EQ(static_cast<const uint32_t*>(at)[n - 1], n - 1);
        ctx.queue().enqueueUnmapMemObject(buffer, at);
        std::vector<uint32_t> back(n);
        ctx.queue().enqueueReadBuffer(buffer, CL_TRUE, 0, n * 4, back.data());
        EXPECT_EQ(back, data);
        ctx.queue().finish();
    }
    ctx.queue().finish();
    EXPECT_FALSE(Mapped(at));
}

TEST(DeviceBuffer, ReadOnlyAllocHostPtrBuffersMapForWriting) {
    clrt::Context& ctx = Ctx();
    const size_t n = 2 * kLargeAllocationBytes / 4;
    cl::Buffer buffer = DeviceBuffer(ctx, n * 4, CL_MEM_READ_ONLY | CL_MEM_ALLOC_HOST_PTR);
    EXPECT_EQ(buffer.getInfo<CL_MEM_FLAGS>() & CL_MEM_ALLOC_HOST_PTR, 0u);
    auto* out = static_cast<uint32_t*>(
        ctx.queue().enqueueMapBuffer(buffer, CL_TRUE, CL_MAP_WRITE_INVALIDATE_REGION, 0, n * 4));
    for (size_t i = 0; i < n; ++i) out[i] = uint32_t(3 * i);
    ctx.queue().enqueueUnmapMemObject(buffer, out);
    std::vector<uint32_t> back(n);
    ctx.queue().enqueueReadBuffer(buffer, CL_TRUE, 0, n * 4, back.data());
    EXPECT_EQ(back[n - 1], uint32_t(3 * (n - 1)));
}

TEST(DeviceBuffer, SmallOnesAreTheDevicesOwn) {
    cl::Buffer buffer = DeviceBuffer(Ctx(), kLargeAllocationBytes - 1);
    EXPECT_EQ(buffer.getInfo<CL_MEM_FLAGS>() & CL_MEM_USE_HOST_PTR, 0u);
    EXPECT_EQ(buffer.getInfo<CL_MEM_SIZE>(), kLargeAllocationBytes - 1);
    EXPECT_EQ(DeviceBuffer(Ctx(), 0).getInfo<CL_MEM_SIZE>(), 1u);
}

}  // namespace
}  // namespace rayclass::render
