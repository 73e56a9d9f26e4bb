#include "rayclass/image/compare.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "rayclass/core/error.h"

namespace rayclass::image {

namespace {

double Difference(float a, float b) {
    if (a == b || (std::isnan(a) && std::isnan(b))) return 0.0;
    double d = std::abs(double(a) - double(b));
    // Only a NaN against a number gets here as NaN; it must fail any bound, not slip past one.
    return std::isnan(d) ? std::numeric_limits<double>::infinity() : d;
}

}  // namespace

ImageComparison Compare(const Image& a, const Image& b) {
    if (a.width != b.width || a.height != b.height) {
        throw Error("images differ in size: " + std::to_string(a.width) + "x" +
                    std::to_string(a.height) + " vs " + std::to_string(b.width) + "x" +
                    std::to_string(b.height));
    }
    ImageComparison result;
    size_t pixels = a.PixelCount();
    double sumAbs = 0.0;
    double sumSquared = 0.0;
    for (size_t i = 0; i < pixels; ++i) {
        for (int c = 0; c < 3; ++c) {
            double d = Difference(a.rgb[i][c], b.rgb[i][c]);
            sumAbs += d;
            sumSquared += d * d;
            result.maxAbsError = std::max(result.maxAbsError, d);
        }
    }
    double mse = 0.0;
    if (pixels > 0) {
        double values = 3.0 * double(pixels);
        result.meanAbsError = sumAbs / values;
        mse = sumSquared / values;
        result.rmse = std::sqrt(mse);
    }
    result.psnrDb = mse > 0.0 ? -10.0 * std::log10(mse) : std::numeric_limits<double>::infinity();
    if (a.id.size() == pixels && b.id.size() == pixels && pixels > 0) {
        result.hasIds = true;
        for (size_t i = 0; i < pixels; ++i) result.idMismatchPixels += a.id[i] != b.id[i];
        result.idMismatchFraction = double(result.idMismatchPixels) / double(pixels);
    }
    return result;
}

}  // namespace rayclass::image
