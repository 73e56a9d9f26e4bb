#include "rayclass/image/compare.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "rayclass/core/error.h"

namespace rayclass::image {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(CompareTest, IdenticalImages) {
    Image a(2, 1);
    a.rgb = {glm::vec3(0.1f, 0.2f, 0.3f), glm::vec3(1e6f)};
    ImageComparison result = Compare(a, a);
    EXPECT_EQ(result.meanAbsError, 0.0);
    EXPECT_EQ(result.rmse, 0.0);
    EXPECT_EQ(result.maxAbsError, 0.0);
    EXPECT_EQ(result.psnrDb, kInf);
    EXPECT_FALSE(result.hasIds);
}

TEST(CompareTest, HandComputedMetrics) {
    Image a(2, 1);
    a.rgb = {glm::vec3(0.0f), glm::vec3(1.0f)};
    Image b(2, 1);
    b.rgb = {glm::vec3(0.5f, 0.0f, 0.0f), glm::vec3(1.0f, 1.0f, 0.0f)};
    // Differences 0.5, 0, 0, 0, 0, 1: sum 1.5, sum of squares 1.25, over 6 values.
    ImageComparison result = Compare(a, b);
    EXPECT_EQ(result.meanAbsError, 0.25);
    EXPECT_EQ(result.rmse, std::sqrt(1.25 / 6.0));
    EXPECT_DOUBLE_EQ(result.psnrDb, 10.0 * std::log10(6.0 / 1.25));
    EXPECT_EQ(result.maxAbsError, 1.0);
    EXPECT_FALSE(result.hasIds);
}

TEST(CompareTest, IdMismatchNeedsBothLayers) {
    Image a(2, 2);
    a.id = {1, 2, 3, 4};
    Image b(2, 2);
    EXPECT_FALSE(Compare(a, b).hasIds);
    b.id = {1, 2, 7, 4};
    ImageComparison result = Compare(a, b);
    EXPECT_TRUE(result.hasIds);
    EXPECT_EQ(result.idMismatchPixels, 1u);
    EXPECT_EQ(result.idMismatchFraction, 0.25);
    EXPECT_EQ(result.rmse, 0.0);
}

TEST(CompareTest, NanCountsOnlyAgainstANumber) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    Image a(1, 1);
    a.rgb = {glm::vec3(nan, inf, 0.0f)};
    Image b = a;
    EXPECT_EQ(Compare(a, b).maxAbsError, 0.0);
    b.rgb[0].x = 0.0f;
    ImageComparison result = Compare(a, b);
    EXPECT_EQ(result.maxAbsError, kInf);
    EXPECT_EQ(result.meanAbsError, kInf);
    EXPECT_EQ(result.rmse, kInf);
}

TEST(CompareTest, SizeMismatchThrows) {
    try {
        Compare(Image(800, 600), Image(640, 480));
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_STREQ(e.what(), "images differ in size: 800x600 vs 640x480");
    }
}

}  // namespace
}  // namespace rayclass::image
