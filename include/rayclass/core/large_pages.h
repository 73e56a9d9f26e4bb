// Large host arrays in pages of their own, advised for transparent huge pages (Linux's
// MADV_HUGEPAGE; Debian's default THP mode honours only advised memory). A one-frame render
// first-touches most of its memory, so on 4 KiB pages its page faults are a large part of its
// time; with its device buffers and leaf arrays on huge pages about half of them go.
#pragma once

#include <cstddef>

namespace rayclass {

constexpr size_t kHugePageBytes = size_t(2) << 20;

// Allocations of this many bytes or more take the large path (below it, malloc's reuse of
// freed memory saves more than huge pages would).
constexpr size_t kLargeAllocationBytes = kHugePageBytes;

// `bytes` (> 0) of zeroed memory aligned to kHugePageBytes, mapped for this allocation alone
// and advised for huge pages (where the kernel refuses the advice, ordinary pages). Throws
// std::bad_alloc.
void* AllocateLarge(size_t bytes);

// Frees what AllocateLarge(bytes) returned.
void FreeLarge(void* p, size_t bytes) noexcept;

}  // namespace rayclass
