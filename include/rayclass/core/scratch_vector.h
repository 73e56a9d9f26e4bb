// A std::vector for scratch arrays of trivial elements that resize() leaves uninitialised: a
// large buffer whose elements are written before they are read then costs no zeroing pass, and
// pages never written (the unused tail of a worst-case reservation) are never faulted in.
#pragma once

#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

namespace rayclass {

template <typename T>
class UninitializedAllocator : public std::allocator<T> {
  public:
    template <typename U>
    struct rebind {
        using other = UninitializedAllocator<U>;
    };
    UninitializedAllocator() = default;
    template <typename U>
    UninitializedAllocator(const UninitializedAllocator<U>&) noexcept {}

    template <typename U>
    void construct(U* p) noexcept {
        static_assert(std::is_trivially_default_constructible_v<U>);
        ::new (static_cast<void*>(p)) U;
    }
    template <typename U, typename... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};

template <typename T>
using ScratchVector = std::vector<T, UninitializedAllocator<T>>;

}  // namespace rayclass
