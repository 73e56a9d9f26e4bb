// Two counters per ray that the kd-tree, grid and cone kernels write: counters[i] the primitive
// tests of ray i, counters[n + i] the structure's own steps for it (nodes or cells visited).
#pragma once

#include <cstdint>
#include <numeric>
#include <vector>

#include "rayclass/render/launch.h"

namespace rayclass::render {

struct CounterSums {
    uint64_t tests = 0, steps = 0;
};

class RayCounters {
  public:
    const cl::Buffer& Reserve(clrt::Context& ctx, uint32_t n) {
        return buffer_.Reserve(ctx, size_t(2) * n * sizeof(uint32_t));
    }

    // Reads the counters of the last n rays back and sums each half.
    CounterSums Sum(clrt::Context& ctx, uint32_t n) {
        if (n == 0) return {};
        SumCounters(ctx, Reserve(ctx, n), 2 * n, scratch_);
        return {std::accumulate(scratch_.begin(), scratch_.begin() + n, uint64_t(0)),
                std::accumulate(scratch_.begin() + n, scratch_.end(), uint64_t(0))};
    }

  private:
    GrowingBuffer buffer_;
    std::vector<uint32_t> scratch_;
};

}  // namespace rayclass::render
