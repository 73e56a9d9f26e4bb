// Which of the vector paths that are chosen at run time a process may take. Every such path
// computes exactly what its generic twin computes; the choice exists so that tests and users
// can run the generic twins on a CPU that has the extensions.
#pragma once

namespace rayclass {

enum class SimdRequest { kAuto, kAvx512, kGeneric };

// RAYCLASS_SIMD, read once: auto (the default: each path checks the CPU), avx512 (insist on
// the AVX-512 paths) or generic (only the generic twins). Throws on any other value.
SimdRequest RequestedSimd();

}  // namespace rayclass
