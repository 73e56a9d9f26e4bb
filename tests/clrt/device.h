// The OpenCL device the clrt suites run on: PoCL's CPU device, one context per test binary
// (creating a context and building a program take seconds, so tests share them).
#pragma once

#include <string>
#include <vector>

#include "rayclass/clrt/context.h"
#include "test_device.h"

namespace rayclass::clrt::testing {

inline Context& TestContext() {
    static Context context(TestDeviceSpec());
    return context;
}

// The options the renderer builds with (BuildRenderProgram), so probes see the same compiler.
inline constexpr const char* kProbeOptions = "-cl-std=CL1.2 -DRC_LOCAL_SIZE=64";

// Copies `v` into a read-only device buffer (one element when empty: OpenCL rejects size 0).
template <typename T>
cl::Buffer Upload(const std::vector<T>& v) {
    std::vector<T> copy = v.empty() ? std::vector<T>(1) : v;
    return cl::Buffer(TestContext().context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR,
                      copy.size() * sizeof(T), copy.data());
}

template <typename T>
std::vector<T> Download(const cl::Buffer& buffer, size_t n) {
    std::vector<T> v(n);
    if (n) TestContext().queue().enqueueReadBuffer(buffer, CL_TRUE, 0, n * sizeof(T), v.data());
    return v;
}

}  // namespace rayclass::clrt::testing
