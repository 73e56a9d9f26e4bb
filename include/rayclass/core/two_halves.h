// Work over an index range split between the calling thread and one other.
#pragma once

#include <cstddef>

#include "rayclass/core/helper_threads.h"

namespace rayclass {

// Calls fn(begin, end) over [0, n): the upper half on a second thread while this one does the
// lower half, when n is at least `minParallel` (below it the handing over costs more than it
// saves); else once over the whole range. fn must be safe to run on two disjoint ranges at once,
// and in either order (see OnHelpers).
template <typename Fn>
void InTwoHalves(size_t n, size_t minParallel, Fn&& fn) {
    if (n < minParallel) {
        fn(size_t(0), n);
        return;
    }
    OnHelpers(2, [&fn, n](int half) { half == 0 ? fn(size_t(0), n / 2) : fn(n / 2, n); });
}

}  // namespace rayclass
