// Large host arrays: page-aligned, zeroed, writable to the last byte, not advised for huge
// pages, faulted in ahead on request, and returned to the system when freed;
// DenseScratchVector takes that path from kLargeAllocationBytes on, ScratchVector never.
#include "rayclass/core/large_pages.h"

#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/mapped.h"
#include "rayclass/core/scratch_vector.h"

namespace rayclass {
namespace {

bool Aligned(const void* p) {
    return reinterpret_cast<uintptr_t>(p) % uintptr_t(sysconf(_SC_PAGESIZE)) == 0;
}

using testing::Mapped;

// The "THPeligible:" field of /proc/self/smaps for the mapping that starts at p ("" if none).
std::string ThpEligible(const void* p) {
    std::ifstream smaps("/proc/self/smaps");
    std::string line;
    bool inside = false;
    while (std::getline(smaps, line)) {
        uintptr_t lo = 0, hi = 0;
        char dash = 0;
        std::istringstream head(line);
        if (head >> std::hex >> lo >> dash >> hi && dash == '-') {
            inside = lo <= reinterpret_cast<uintptr_t>(p) && reinterpret_cast<uintptr_t>(p) < hi;
        } else if (inside && line.rfind("THPeligible:", 0) == 0) {
            return line.substr(line.find_first_not_of(" \t", 12));
        }
    }
    return "";
}

// Whether this kernel gives huge pages to advised memory only.
bool ThpMadviseMode() {
    std::ifstream mode("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string text((std::istreambuf_iterator<char>(mode)), std::istreambuf_iterator<char>());
    return text.find("[madvise]") != std::string::npos;
}

TEST(LargePages, AlignedZeroedAndWritableToTheLastByte) {
    for (size_t bytes : {size_t(1), kLargeAllocationBytes - 1, kLargeAllocationBytes,
                         3 * kLargeAllocationBytes + 5}) {
        auto* p = static_cast<unsigned char*>(AllocateLarge(bytes));
        ASSERT_TRUE(Aligned(p)) << bytes;
        EXPECT_EQ(p[0], 0);
        EXPECT_EQ(p[bytes - 1], 0);
        p[0] = 1;
        p[bytes - 1] = 2;
        EXPECT_EQ(p[bytes - 1], 2);
        if (bytes > 1) {
            EXPECT_EQ(p[0], 1);
        }
        FreeLarge(p, bytes);
        EXPECT_FALSE(Mapped(p)) << bytes;
    }
}

// In the kernel's "madvise" mode a mapping is eligible only when advised: so it stays on 4 KiB
// pages. ("always" makes every mapping eligible, whatever this code does.)
TEST(LargePages, NotAdvisedForHugePages) {
    if (!ThpMadviseMode()) GTEST_SKIP() << "transparent huge pages are not in madvise mode";
    const size_t bytes = 4 * kLargeAllocationBytes;
    void* p = AllocateLarge(bytes);
    EXPECT_EQ(ThpEligible(p), "0");
    FreeLarge(p, bytes);
}

// Which of the pages of [p, p + bytes) (p page-aligned) are in memory, as mincore says.
std::vector<bool> Resident(void* p, size_t bytes) {
    const auto page = size_t(sysconf(_SC_PAGESIZE));
    std::vector<unsigned char> in((bytes + page - 1) / page);
    EXPECT_EQ(mincore(p, bytes, in.data()), 0);
    std::vector<bool> out;
    for (unsigned char c : in) out.push_back(c & 1);
    return out;
}

TEST(LargePages, PopulateFaultsInTheRangeItIsGivenAndKeepsItZero) {
    const auto page = size_t(sysconf(_SC_PAGESIZE));
    const size_t bytes = 16 * page;
    auto* p = static_cast<unsigned char*>(AllocateLarge(bytes));
    EXPECT_EQ(Resident(p, bytes), std::vector<bool>(16, false));
    // From the middle of page 2 to the middle of page 5: pages 2 to 5.
    PopulateLarge(p + 2 * page + page / 2, 3 * page);
    const std::vector<bool> resident = Resident(p, bytes);
#ifdef MADV_POPULATE_WRITE
    if (resident[2]) {  // else a kernel before Linux 5.14, which cannot
        for (size_t k = 0; k < 16; ++k) EXPECT_EQ(resident[k], k >= 2 && k <= 5) << k;
    }
#endif
    for (size_t i = 0; i < bytes; ++i) ASSERT_EQ(p[i], 0) << i;
    FreeLarge(p, bytes);
}

TEST(LargePages, RefusesWhatCannotBeMapped) {
    EXPECT_THROW(AllocateLarge(0), std::bad_alloc);
    EXPECT_THROW(AllocateLarge(SIZE_MAX - 100), std::bad_alloc);
}

TEST(LargePages, DenseScratchVectorTakesTheLargePathFromTheThreshold) {
    DenseScratchVector<uint32_t> small(kLargeAllocationBytes / 4 - 1);
    DenseScratchVector<uint32_t> large(kLargeAllocationBytes / 4);
    EXPECT_TRUE(Aligned(large.data()));
    // A small one comes from malloc, whose chunks start 16 bytes into a mapping.
    EXPECT_FALSE(Aligned(small.data()));
    large.back() = 7;
    const uint32_t* before = large.data();
    large.resize(3 * large.size());  // reallocates: the old pages go back
    EXPECT_EQ(large[kLargeAllocationBytes / 4 - 1], 7u);
    EXPECT_FALSE(Mapped(before));
}

TEST(LargePages, ScratchVectorStaysOnMallocsPages) {
    ScratchVector<uint32_t> v(4 * kLargeAllocationBytes / 4);
    EXPECT_FALSE(Aligned(v.data()));
}

}  // namespace
}  // namespace rayclass
