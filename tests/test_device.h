// The OpenCL device the OpenCL-facing suites run on: $RAYCLASS_TEST_DEVICE, a `--device` spec
// (cpu, gpu, auto or an index from `rayclass devices`; scripts/gpu-check sets a GPU's index),
// and PoCL's CPU device when it is unset, as CI runs them.
#pragma once

#include <cstdlib>
#include <string>

namespace rayclass {

inline std::string TestDeviceSpec() {
    const char* spec = std::getenv("RAYCLASS_TEST_DEVICE");
    return spec && *spec ? spec : "cpu";
}

}  // namespace rayclass
