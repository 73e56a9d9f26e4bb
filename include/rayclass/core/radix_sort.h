// Stable sorting of ids by a float key in three least-significant-digit radix passes over the
// keys' bits made orderable as unsigned integers: linear in n, and no comparison reads a key
// through an index (std::sort with such a comparator is slow on large meshes: a random read per
// comparison).
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <span>
#include <vector>

namespace rayclass {

// Arrays the sorts work in, kept between calls by a caller that sorts many times: fresh ones
// cost their page faults every time.
struct RadixScratch {
    std::vector<uint32_t> bits, nextBits, nextOrder;
};

// Reorders `order` stably by the low `keyBits` bits of `bits`, its keys, which are reordered
// with it: least significant digit first, kDigitBits a pass. Works in scratch.nextBits and
// scratch.nextOrder; `bits` may be scratch.bits.
template <int kDigitBits>
inline void RadixSortByBits(std::vector<uint32_t>& bits, std::vector<uint32_t>& order, int keyBits,
                            RadixScratch& scratch) {
    const size_t n = bits.size();
    scratch.nextBits.resize(n);
    scratch.nextOrder.resize(n);
    constexpr uint32_t kBuckets = 1u << kDigitBits;
    for (int shift = 0; shift < keyBits; shift += kDigitBits) {
        std::array<uint32_t, kBuckets> start{};
        for (size_t i = 0; i < n; ++i) ++start[(bits[i] >> shift) & (kBuckets - 1)];
        // A digit every key shares leaves the order as it is.
        if (n > 0 && start[(bits[0] >> shift) & (kBuckets - 1)] == n) continue;
        uint32_t at = 0;
        for (uint32_t& s : start) {
            const uint32_t count = s;
            s = at;
            at += count;
        }
        for (size_t i = 0; i < n; ++i) {
            const uint32_t to = start[(bits[i] >> shift) & (kBuckets - 1)]++;
            scratch.nextBits[to] = bits[i];
            scratch.nextOrder[to] = order[i];
        }
        bits.swap(scratch.nextBits);
        order.swap(scratch.nextOrder);
    }
}

// The ids 0 .. n-1 ordered by keys[id], equal keys by id (so -0 and +0, which compare equal,
// keep id order too), into `order`. No key may be NaN.
inline void SortedOrder(std::span<const float> keys, std::vector<uint32_t>& order,
                        RadixScratch& scratch) {
    const size_t n = keys.size();
    std::vector<uint32_t>& bits = scratch.bits;
    bits.resize(n);
    order.resize(n);
    for (size_t i = 0; i < n; ++i) {
        // Adding +0 turns -0 into +0. Negative floats order by the complement of their bits,
        // positive ones after them with the sign bit set.
        const uint32_t u = std::bit_cast<uint32_t>(keys[i] + 0.0f);
        bits[i] = (u & 0x80000000u) ? ~u : (u | 0x80000000u);
        order[i] = uint32_t(i);
    }
    RadixSortByBits<11>(bits, order, 32, scratch);
}

inline std::vector<uint32_t> SortedOrder(std::span<const float> keys) {
    RadixScratch scratch;
    std::vector<uint32_t> order;
    SortedOrder(keys, order, scratch);
    return order;
}

}  // namespace rayclass
