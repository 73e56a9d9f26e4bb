// A std::vector for scratch arrays of trivial elements that resize() leaves uninitialised: a
// large buffer whose elements are written before they are read then costs no zeroing pass, and
// pages never written (the unused tail of a worst-case reservation) are never faulted in.
//
// DenseScratchVector, for arrays that are written from the front without gaps, takes pages of
// its own from kLargeAllocationBytes on (large_pages.h), returned to the system when freed.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

#include "rayclass/core/large_pages.h"

namespace rayclass {

template <typename T, bool kLargePages = false>
class UninitializedAllocator : public std::allocator<T> {
  public:
    template <typename U>
    struct rebind {
        using other = UninitializedAllocator<U, kLargePages>;
    };
    UninitializedAllocator() = default;
    template <typename U>
    UninitializedAllocator(const UninitializedAllocator<U, kLargePages>&) noexcept {}

    template <typename U>
    void construct(U* p) noexcept {
        static_assert(std::is_trivially_default_constructible_v<U>);
        ::new (static_cast<void*>(p)) U;
    }
    template <typename U, typename... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }

    T* allocate(size_t n) {
        if (!Large(n)) return std::allocator<T>::allocate(n);
        if (n > SIZE_MAX / sizeof(T)) throw std::bad_array_new_length();
        return static_cast<T*>(AllocateLarge(n * sizeof(T)));
    }
    void deallocate(T* p, size_t n) noexcept {
        if (!Large(n)) {
            std::allocator<T>::deallocate(p, n);
        } else {
            FreeLarge(p, n * sizeof(T));
        }
    }

  private:
    static bool Large(size_t n) { return kLargePages && n >= kLargeAllocationBytes / sizeof(T); }
};

template <typename T>
using ScratchVector = std::vector<T, UninitializedAllocator<T>>;
template <typename T>
using DenseScratchVector = std::vector<T, UninitializedAllocator<T, true>>;

}  // namespace rayclass
