#include "rayclass/cli/compare_command.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sstream>

#include "image/test_dir.h"
#include "rayclass/image/image.h"

namespace rayclass::cli {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

class CompareCommandTest : public image::testing::TestDir {
  protected:
    void SetUp() override {
        TestDir::SetUp();
        // a vs b: every value differs by 0.5, so mae = rmse = max = 0.5 and psnr = 10 log10(4);
        // the ids differ in one pixel of two.
        image::Image a(2, 1);
        a.rgb = {glm::vec3(0.0f), glm::vec3(1.0f)};
        a.id = {1, 2};
        image::Image b(2, 1);
        b.rgb = {glm::vec3(0.5f), glm::vec3(0.5f)};
        b.id = {1, 3};
        image::WriteImage(a, Path("a.exr"));
        image::WriteImage(b, Path("b.exr"));
        a.id.clear();
        image::WriteImage(a, Path("a_no_id.exr"));
        image::WriteImage(image::Image(1, 1), Path("small.exr"));
    }

    int Run(std::vector<std::string> args) {
        out_.str("");
        err_.str("");
        return CompareCommand(args, out_, err_);
    }
    std::string A() const { return Path("a.exr").string(); }
    std::string B() const { return Path("b.exr").string(); }

    std::ostringstream out_;
    std::ostringstream err_;
};

constexpr const char* kMetrics =
    "mean_abs_error: 0.5\n"
    "rmse: 0.5\n"
    "psnr_db: 6.020599913279624\n"
    "max_abs_error: 0.5\n"
    "id_mismatch_pixels: 1\n"
    "id_mismatch_fraction: 0.5\n";

TEST_F(CompareCommandTest, PrintsMetrics) {
    EXPECT_EQ(Run({A(), B()}), 0);
    EXPECT_EQ(out_.str(), kMetrics);
    EXPECT_EQ(err_.str(), "");
}

TEST_F(CompareCommandTest, IdenticalImagesHaveInfinitePsnr) {
    EXPECT_EQ(Run({A(), A()}), 0);
    EXPECT_EQ(out_.str(),
              "mean_abs_error: 0\nrmse: 0\npsnr_db: inf\nmax_abs_error: 0\n"
              "id_mismatch_pixels: 0\nid_mismatch_fraction: 0\n");
}

TEST_F(CompareCommandTest, IdLinesNeedBothIdLayers) {
    EXPECT_EQ(Run({Path("a_no_id.exr").string(), B()}), 0);
    EXPECT_EQ(out_.str(),
              "mean_abs_error: 0.5\nrmse: 0.5\npsnr_db: 6.020599913279624\n"
              "max_abs_error: 0.5\n");
}

TEST_F(CompareCommandTest, Json) {
    EXPECT_EQ(Run({A(), B(), "--json"}), 0);
    EXPECT_EQ(
        out_.str(),
        "{\"mean_abs_error\": 0.5, \"rmse\": 0.5, \"psnr_db\": 6.020599913279624, "
        "\"max_abs_error\": 0.5, \"id_mismatch_pixels\": 1, \"id_mismatch_fraction\": 0.5}\n");
    EXPECT_EQ(Run({"--json", Path("a_no_id.exr").string(), Path("a_no_id.exr").string()}), 0);
    EXPECT_EQ(out_.str(),
              "{\"mean_abs_error\": 0, \"rmse\": 0, \"psnr_db\": null, \"max_abs_error\": 0}\n");
}

TEST_F(CompareCommandTest, BoundsWithinPass) {
    EXPECT_EQ(Run({A(), B(), "--max-rmse", "0.5", "--max-id-mismatch", "0.5"}), 0);
    EXPECT_EQ(out_.str(), kMetrics);
    EXPECT_EQ(err_.str(), "");
}

TEST_F(CompareCommandTest, ExceededBoundsFail) {
    EXPECT_EQ(Run({A(), B(), "--max-rmse", "0.25"}), 1);
    EXPECT_EQ(out_.str(), kMetrics);
    EXPECT_EQ(err_.str(), "rmse 0.5 exceeds --max-rmse 0.25\n");

    EXPECT_EQ(Run({"--max-id-mismatch", "0.1", A(), B(), "--max-rmse", "0.01"}), 1);
    EXPECT_EQ(err_.str(),
              "rmse 0.5 exceeds --max-rmse 0.01\n"
              "id_mismatch_fraction 0.5 exceeds --max-id-mismatch 0.1\n");
}

TEST_F(CompareCommandTest, SizeMismatchFails) {
    EXPECT_EQ(Run({A(), Path("small.exr").string()}), 1);
    EXPECT_EQ(out_.str(), "");
    EXPECT_EQ(err_.str(), "images differ in size: 2x1 vs 1x1\n");
}

TEST_F(CompareCommandTest, UnreadableInput) {
    EXPECT_EQ(Run({A(), Path("missing.exr").string()}), 2);
    EXPECT_EQ(out_.str(), "");
    EXPECT_EQ(err_.str(),
              Path("missing.exr").string() + ": cannot read: No such file or directory\n");
}

TEST_F(CompareCommandTest, IdBoundNeedsIdLayers) {
    EXPECT_EQ(Run({Path("a_no_id.exr").string(), B(), "--max-id-mismatch", "0"}), 2);
    EXPECT_EQ(err_.str(), "--max-id-mismatch needs an id layer in both images; " +
                              Path("a_no_id.exr").string() + " has none\n");
}

TEST_F(CompareCommandTest, BadArguments) {
    const std::string hint = "run 'rayclass compare --help' for usage\n";
    EXPECT_EQ(Run({}), 2);
    EXPECT_EQ(err_.str(), "expected two image files, got 0\n" + hint);
    EXPECT_EQ(Run({A(), B(), A()}), 2);
    EXPECT_EQ(err_.str(), "expected two image files, got 3\n" + hint);
    EXPECT_EQ(Run({A(), B(), "--fast"}), 2);
    EXPECT_EQ(err_.str(), "unknown option '--fast'\n" + hint);
    EXPECT_EQ(Run({A(), B(), "--max-rmse"}), 2);
    EXPECT_EQ(err_.str(), "--max-rmse needs a value\n" + hint);
    for (const char* bad : {"abc", "-1", "nan", "inf", "0.1x", ""}) {
        EXPECT_EQ(Run({A(), B(), "--max-rmse", bad}), 2) << bad;
        EXPECT_EQ(err_.str(), "--max-rmse needs a non-negative number, got '" + std::string(bad) +
                                  "'\n" + hint);
    }
    EXPECT_EQ(out_.str(), "");
}

TEST_F(CompareCommandTest, Help) {
    EXPECT_EQ(Run({"--help"}), 0);
    EXPECT_THAT(out_.str(), StartsWith("usage: rayclass compare A B [--max-rmse X] "
                                       "[--max-id-mismatch FRACTION] [--json]\n"));
    EXPECT_THAT(out_.str(), HasSubstr("Exit status"));
    EXPECT_EQ(err_.str(), "");
}

}  // namespace
}  // namespace rayclass::cli
