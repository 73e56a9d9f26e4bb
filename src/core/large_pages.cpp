#include "rayclass/core/large_pages.h"

#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <new>

namespace rayclass {

void* AllocateLarge(size_t bytes) {
    if (bytes == 0 || bytes > SIZE_MAX / 2) throw std::bad_alloc();
    void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) throw std::bad_alloc();
    return p;
}

void FreeLarge(void* p, size_t bytes) noexcept {
    if (p) munmap(p, bytes);
}

void PopulateLarge(void* p, size_t bytes) noexcept {
#ifdef MADV_POPULATE_WRITE
    // madvise takes whole pages: the range's first page from its start.
    const auto page = uintptr_t(sysconf(_SC_PAGESIZE));
    const uintptr_t first = uintptr_t(p) & ~(page - 1);
    // A kernel without it (before Linux 5.14) leaves the pages to their first writes.
    madvise(reinterpret_cast<void*>(first), uintptr_t(p) + bytes - first, MADV_POPULATE_WRITE);
#else
    (void)p, (void)bytes;
#endif
}

}  // namespace rayclass
