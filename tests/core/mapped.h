// Whether the page holding `p` is mapped in this process (mincore fails with ENOMEM on an
// unmapped range): for tests of memory that must be returned to the system.
#pragma once

#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>

namespace rayclass::testing {

inline bool Mapped(const void* p) {
    unsigned char resident;
    const uintptr_t pageSize = uintptr_t(sysconf(_SC_PAGESIZE));
    const uintptr_t page = reinterpret_cast<uintptr_t>(p) / pageSize * pageSize;
    return mincore(reinterpret_cast<void*>(page), 1, &resident) == 0 || errno != ENOMEM;
}

}  // namespace rayclass::testing
