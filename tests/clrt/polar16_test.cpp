// The polar16 direction encoding (cl/encoding.cl) against its documented bound: 5.36e-5 rad of
// angular error from the 16-bit steps, plus float rounding, everywhere, including the poles (theta near 0 and pi) where polar coordinates
// degenerate and the seam at phi = +-pi.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "clrt/device.h"
#include "rc_types.h"

namespace rayclass::clrt {
namespace {

using testing::Download;
using testing::TestContext;
using testing::Upload;

std::vector<rc_float4> RoundTrip(const std::vector<rc_float4>& in) {
    static const cl::Program program =
        TestContext().BuildProgram({"encoding.cl"}, testing::kProbeOptions);
    cl::Kernel kernel(program, "rc_polar16_roundtrip");
    const cl::Buffer inBuf = Upload(in);
    cl::Buffer outBuf(TestContext().context(), CL_MEM_WRITE_ONLY, in.size() * sizeof(rc_float4));
    kernel.setArg(0, inBuf);
    kernel.setArg(1, uint32_t(in.size()));
    kernel.setArg(2, outBuf);
    TestContext().queue().enqueueNDRangeKernel(
        kernel, cl::NullRange, cl::NDRange(RoundUp(in.size(), 64)), cl::NDRange(64));
    return Download<rc_float4>(outBuf, in.size());
}

// atan2 of |a x b| and a . b stays accurate for tiny angles, where acos does not.
double AngleBetween(const rc_float4& a, const rc_float4& b) {
    const double dot = double(a.x) * b.x + double(a.y) * b.y + double(a.z) * b.z;
    const double cx = double(a.y) * b.z - double(a.z) * b.y;
    const double cy = double(a.z) * b.x - double(a.x) * b.z;
    const double cz = double(a.x) * b.y - double(a.y) * b.x;
    return std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), dot);
}

rc_float4 Unit(double x, double y, double z) {
    const double l = std::sqrt(x * x + y * y + z * z);
    return {float(x / l), float(y / l), float(z / l), 0.0f};
}

constexpr double kBound = 5.5e-5;  // rad: 5.36e-5 from the steps (cl/encoding.cl) + rounding

TEST(Polar16, RandomDirectionsStayWithinTheBound) {
    std::mt19937 rng(7);
    std::normal_distribution<double> n(0.0, 1.0);
    std::vector<rc_float4> in;
    for (int i = 0; i < 100000; ++i) in.push_back(Unit(n(rng), n(rng), n(rng)));
    const auto out = RoundTrip(in);
    double worst = 0.0;
    for (size_t i = 0; i < in.size(); ++i) worst = std::max(worst, AngleBetween(in[i], out[i]));
    RecordProperty("worst_rad", std::to_string(worst));
    EXPECT_LE(worst, kBound);
    EXPECT_GT(worst, 1e-6);  // the encoding does lose precision: this test measures it
}

TEST(Polar16, PolesAndSeamStayWithinTheBound) {
    std::vector<rc_float4> in;
    for (double eps : {0.0, 1e-9, 1e-6, 1e-4, 1e-2}) {
        for (double phi = -M_PI; phi <= M_PI; phi += M_PI / 16) {
            for (double z : {1.0, -1.0}) {
                in.push_back(Unit(eps * std::cos(phi), eps * std::sin(phi), z));
            }
        }
        // Around the seam phi = +-pi (negative x axis), above and below it.
        in.push_back(Unit(-1.0, eps, 0.3));
        in.push_back(Unit(-1.0, -eps, 0.3));
    }
    const auto out = RoundTrip(in);
    for (size_t i = 0; i < in.size(); ++i) {
        EXPECT_LE(AngleBetween(in[i], out[i]), kBound)
            << in[i].x << " " << in[i].y << " " << in[i].z;
        const double len = std::sqrt(double(out[i].x) * out[i].x + double(out[i].y) * out[i].y +
                                     double(out[i].z) * out[i].z);
        EXPECT_NEAR(len, 1.0, 1e-6);  // decoded directions are unit vectors
    }
}

}  // namespace
}  // namespace rayclass::clrt
