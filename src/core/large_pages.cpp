#include "rayclass/core/large_pages.h"

#include <sys/mman.h>

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

}  // namespace rayclass
