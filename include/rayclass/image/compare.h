// Difference metrics between two images of the same size, for regression checks.
#pragma once

#include <cstdint>

#include "rayclass/image/image.h"

namespace rayclass::image {

struct ImageComparison {
    // Over the R, G and B values of all pixels. A value that is NaN in exactly one image counts
    // as an infinite difference; equal values (both NaN, both +inf) count as none.
    double meanAbsError = 0.0;
    double rmse = 0.0;
    double psnrDb = 0.0;  // 10 log10(1 / mse), peak 1.0; +inf when the images are identical
    double maxAbsError = 0.0;
    // Set only when both images carry an id layer.
    bool hasIds = false;
    uint64_t idMismatchPixels = 0;
    double idMismatchFraction = 0.0;
};

// Throws rayclass::Error("images differ in size: WxH vs WxH") when the sizes differ, its only
// failure.
ImageComparison Compare(const Image& a, const Image& b);

}  // namespace rayclass::image
