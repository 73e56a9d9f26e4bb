#include "rayclass/core/simd.h"

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
    switch (RequestedSimd()) {
        case SimdRequest::kGeneric:
            return false;
        case SimdRequest::kAuto:
            return CpuHasAvx512();
        case SimdRequest::kAvx512:
            break;
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
