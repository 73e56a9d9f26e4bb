#include "rayclass/core/radix_sort.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

namespace rayclass {
namespace {

// The order std::stable_sort gives ids compared by key, equal keys by id.
std::vector<uint32_t> ComparisonOrder(const std::vector<float>& keys) {
    std::vector<uint32_t> order(keys.size());
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(),
                     [&](uint32_t a, uint32_t b) { return keys[a] < keys[b]; });
    return order;
}

TEST(SortedOrder, EqualsAComparisonSortWithTiesById) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> wide(-1e6f, 1e6f), narrow(-2.0f, 2.0f);
    std::vector<float> keys;
    for (int i = 0; i < 20000; ++i) {
        switch (i % 5) {
            case 0:
                keys.push_back(wide(rng));
                break;
            case 1:
                keys.push_back(narrow(rng));
                break;
            // Repeated values, both zeros, infinities and denormals: the ties and the corners
            // of the bit mapping.
            case 2:
                keys.push_back(float(int(narrow(rng) * 4.0f)));
                break;
            case 3:
                keys.push_back(i % 2 ? -0.0f : 0.0f);
                break;
            default: {
                const float special[] = {INFINITY, -INFINITY, 1e-42f, -1e-42f, 3.4e38f, -3.4e38f};
                keys.push_back(special[i % 6]);
            }
        }
    }
    std::shuffle(keys.begin(), keys.end(), rng);
    EXPECT_EQ(SortedOrder(keys), ComparisonOrder(keys));
}

TEST(SortedOrder, HandlesEmptyAndConstantKeys) {
    EXPECT_TRUE(SortedOrder({}).empty());
    const std::vector<float> same(100, 2.5f);
    EXPECT_EQ(SortedOrder(same), ComparisonOrder(same));
}

}  // namespace
}  // namespace rayclass
