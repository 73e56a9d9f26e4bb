#include "rayclass/core/large_pages.h"

#include <sys/mman.h>

#include <cstdint>
#include <new>

namespace rayclass {

namespace {

size_t RoundUp(size_t bytes) {
    return (bytes + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
}

}  // namespace

void* AllocateLarge(size_t bytes) {
    if (bytes == 0 || bytes > SIZE_MAX / 2) throw std::bad_alloc();
    const size_t size = RoundUp(bytes);
    // mmap aligns to 4 KiB only: map a huge page more and trim both ends.
    const size_t reserve = size + kHugePageBytes;
    void* base = mmap(nullptr, reserve, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (base == MAP_FAILED) throw std::bad_alloc();
    const uintptr_t lo = reinterpret_cast<uintptr_t>(base);
    const uintptr_t aligned = (lo + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
    if (aligned > lo) munmap(base, aligned - lo);
    const uintptr_t end = aligned + size, reserveEnd = lo + reserve;
    if (reserveEnd > end) munmap(reinterpret_cast<void*>(end), reserveEnd - end);
    void* p = reinterpret_cast<void*>(aligned);
#ifdef MADV_HUGEPAGE
    // Refused (EINVAL) where THP is compiled out: the pages are then ordinary ones.
    madvise(p, size, MADV_HUGEPAGE);
#endif
    return p;
}

void FreeLarge(void* p, size_t bytes) noexcept {
    if (p) munmap(p, RoundUp(bytes));
}

}  // namespace rayclass
