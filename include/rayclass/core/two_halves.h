// Work over an index range split between the calling thread and one other.
#pragma once

#include <cstddef>
#include <future>

namespace rayclass {

// Calls fn(begin, end) over [0, n): the upper half on a second thread while this one does the
// lower half, when n is at least `minParallel` (below it the thread's start costs more than it
// saves); else once over the whole range. fn must be safe to run on two disjoint ranges at once.
template <typename Fn>
void InTwoHalves(size_t n, size_t minParallel, Fn&& fn) {
    if (n < minParallel) {
        fn(size_t(0), n);
        return;
    }
    auto upper = std::async(std::launch::async, [&fn, n] { fn(n / 2, n); });
    fn(size_t(0), n / 2);
    upper.get();
}

}  // namespace rayclass
