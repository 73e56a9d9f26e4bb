// The PNG tone curve's table against its formula: every float within 8192 steps of each
// byte's first float, a stride through the rest of [0, 1], and values outside it.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

#include "formats.h"

namespace rayclass::image::detail {
namespace {

TEST(Srgb8, TableGivesTheFormulasByteAroundEveryStep) {
    const uint32_t one = std::bit_cast<uint32_t>(1.0f);
    uint64_t checked = 0;
    uint32_t prev = 0;
    int steps = 0;
    for (uint32_t bits = 0; bits <= one; bits += bits < one - 4099 ? 4099 : 1) {
        const float v = std::bit_cast<float>(bits);
        ASSERT_EQ(EncodeSrgb8(v), EncodeSrgb8Formula(v)) << v;
        const uint32_t code = EncodeSrgb8Formula(v);
        if (code == prev) continue;
        // A step lies between the previous sample and this one: find its first float and
        // compare everything around it.
        uint32_t lo = bits - (bits < 4099 ? bits : 4099), hi = bits;
        while (hi - lo > 1) {
            const uint32_t mid = lo + (hi - lo) / 2;
            (EncodeSrgb8Formula(std::bit_cast<float>(mid)) >= code ? hi : lo) = mid;
        }
        for (uint32_t b = hi - std::min(hi, 8192u); b <= std::min(one, hi + 8192u); ++b) {
            const float w = std::bit_cast<float>(b);
            ASSERT_EQ(EncodeSrgb8(w), EncodeSrgb8Formula(w)) << w;
            ++checked;
        }
        steps += int(code - prev);
        prev = code;
    }
    EXPECT_EQ(steps, 255);
    EXPECT_GT(checked, 255u * 16000u);
}

TEST(Srgb8, OutsideTheUnitIntervalClampsAsTheFormula) {
    const float inf = std::numeric_limits<float>::infinity();
    for (float v : {-inf, -1.0f, -0.0f, 0.0f, std::numeric_limits<float>::denorm_min(),
                    std::numeric_limits<float>::min(), 1.0f, std::nextafter(1.0f, 2.0f), 7.5f, inf,
                    std::numeric_limits<float>::quiet_NaN()}) {
        EXPECT_EQ(EncodeSrgb8(v), EncodeSrgb8Formula(v)) << v;
    }
    EXPECT_EQ(EncodeSrgb8(std::numeric_limits<float>::quiet_NaN()), 0);
    EXPECT_EQ(EncodeSrgb8(inf), 255);
    EXPECT_EQ(EncodeSrgb8(0.5f), 188);
}

}  // namespace
}  // namespace rayclass::image::detail
