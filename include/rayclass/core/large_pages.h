// Large host arrays in pages of their own: mapped for one allocation, faulted in only where
// written, and returned to the system when freed. They stay on ordinary 4 KiB pages: on a
// virtual machine that hands its guests' free memory back to the host (free page reporting),
// each fresh transparent huge page first costs the host's faults for all of its 2 MiB, many
// times the small pages' faults for the same bytes.
#pragma once

#include <cstddef>

namespace rayclass {

// Allocations of this many bytes or more take the large path (below it, malloc's reuse of
// freed memory saves more).
constexpr size_t kLargeAllocationBytes = size_t(2) << 20;

// `bytes` (> 0) of zeroed, page-aligned memory, mapped for this allocation alone. Throws
// std::bad_alloc.
void* AllocateLarge(size_t bytes);

// Frees what AllocateLarge(bytes) returned.
void FreeLarge(void* p, size_t bytes) noexcept;

// Faults in the pages of [p, p + bytes) (within one AllocateLarge allocation) ahead of their
// first writes, where the system can (MADV_POPULATE_WRITE); their contents stay zero.
void PopulateLarge(void* p, size_t bytes) noexcept;

}  // namespace rayclass
