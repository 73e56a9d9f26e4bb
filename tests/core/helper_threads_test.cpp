// OnHelpers runs every call once, whichever thread runs it, also for calls made at once from
// several threads and from within a call, and hands a call's exception to the caller.
#include "rayclass/core/helper_threads.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

namespace rayclass {
namespace {

TEST(OnHelpers, RunsEveryCallOnce) {
    for (int n = 0; n <= 9; ++n) {
        std::vector<std::atomic<int>> runs(static_cast<size_t>(n));
        OnHelpers(n, [&](int t) { ++runs[size_t(t)]; });
        for (int t = 0; t < n; ++t) EXPECT_EQ(runs[size_t(t)], 1) << "n " << n << " call " << t;
    }
}

TEST(OnHelpers, RunsCallZeroOnTheCallingThread) {
    const std::thread::id caller = std::this_thread::get_id();
    std::thread::id zero;
    OnHelpers(4, [&](int t) {
        if (t == 0) zero = std::this_thread::get_id();
    });
    EXPECT_EQ(zero, caller);
}

// Call 1 goes to a helper while the caller is still busy with call 0 (which waits for it, with
// a bound, so that a serial OnHelpers fails instead of hanging).
TEST(OnHelpers, AHelperTakesACallWhileTheCallerIsBusy) {
    const std::thread::id caller = std::this_thread::get_id();
    std::atomic<bool> begun{false};
    std::thread::id one;
    bool seenByZero = false;
    OnHelpers(2, [&](int t) {
        if (t == 1) {
            one = std::this_thread::get_id();
            begun = true;
            return;
        }
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
        while (!begun && std::chrono::steady_clock::now() < until) std::this_thread::yield();
        seenByZero = begun;
    });
    EXPECT_TRUE(seenByZero);
    EXPECT_NE(one, caller);
}

TEST(OnHelpers, NestedAndConcurrentCallsRunEveryCallOnce) {
    constexpr int kOuter = 3, kInner = 5, kCallers = 4, kRounds = 50;
    std::vector<std::atomic<int>> runs(size_t(kCallers * kOuter * kInner));
    std::vector<std::thread> callers;
    for (int c = 0; c < kCallers; ++c) {
        callers.emplace_back([&, c] {
            for (int round = 0; round < kRounds; ++round) {
                OnHelpers(kOuter, [&](int o) {
                    OnHelpers(kInner,
                              [&](int i) { ++runs[size_t((c * kOuter + o) * kInner + i)]; });
                });
            }
        });
    }
    for (std::thread& t : callers) t.join();
    for (const std::atomic<int>& r : runs) EXPECT_EQ(r, kRounds);
}

TEST(OnHelpers, RethrowsACallsException) {
    std::atomic<int> done{0};
    EXPECT_THROW(OnHelpers(3,
                           [&](int t) {
                               if (t == 2) throw std::runtime_error("call 2");
                               ++done;
                           }),
                 std::runtime_error);
    EXPECT_LE(done, 2);
    // The helpers serve later calls.
    std::atomic<int> later{0};
    OnHelpers(3, [&](int) { ++later; });
    EXPECT_EQ(later, 3);
}

}  // namespace
}  // namespace rayclass
