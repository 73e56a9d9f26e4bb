#include "rayclass/core/simd.h"

#include <cstdlib>
#include <string>

#include "rayclass/core/error.h"

namespace rayclass {

namespace {

SimdRequest ParseSimdRequest() {
    const char* env = std::getenv("RAYCLASS_SIMD");
    const std::string choice = env ? env : "auto";
    if (choice == "auto") return SimdRequest::kAuto;
    if (choice == "avx512") return SimdRequest::kAvx512;
    if (choice == "generic") return SimdRequest::kGeneric;
    throw Error("RAYCLASS_SIMD must be auto, avx512 or generic, not '" + choice + "'");
}

}  // namespace

SimdRequest RequestedSimd() {
    static const SimdRequest request = ParseSimdRequest();
    return request;
}

}  // namespace rayclass
