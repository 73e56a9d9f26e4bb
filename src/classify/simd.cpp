#include <cstdlib>
#include <string>

#include "avx512.h"
#include "rayclass/core/error.h"

namespace rayclass::classify {

namespace {

bool CpuHasAvx512() {
#if defined(RC_AVX512_PATHS)
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512cd") &&
           __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq") &&
           __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512vbmi2");
#else
    return false;
#endif
}

bool ChooseAvx512() {
    const char* env = std::getenv("RAYCLASS_SIMD");
    const std::string choice = env ? env : "auto";
    if (choice == "generic") return false;
    if (choice == "auto") return CpuHasAvx512();
    if (choice != "avx512") {
        throw Error("RAYCLASS_SIMD must be auto, avx512 or generic, not '" + choice + "'");
    }
    if (!CpuHasAvx512()) {
        throw Error("RAYCLASS_SIMD=avx512: this CPU lacks AVX-512 F, CD, BW, DQ, VL or VBMI2");
    }
    return true;
}

}  // namespace

bool UseAvx512() {
    static const bool use = ChooseAvx512();
    return use;
}

}  // namespace rayclass::classify
