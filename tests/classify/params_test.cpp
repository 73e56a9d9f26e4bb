#include "rayclass/classify/params.h"

#include <gtest/gtest.h>

#include <string>

#include "rayclass/core/error.h"

namespace rayclass::classify {
namespace {

TEST(SetParam, SetsEveryNamedParameter) {
    Params p;
    SetParam(p, "min-rays", "8");
    SetParam(p, "min-candidates", "0");
    SetParam(p, "light-min-candidates", "3");
    SetParam(p, "splits-per-list", "2");
    SetParam(p, "split", "median");
    SetParam(p, "min-origin-fraction", "0.001");
    SetParam(p, "min-dir-fraction", "1e-5");
    SetParam(p, "dir-weight", "0.5");
    SetParam(p, "threads", "3");
    SetParam(p, "task-rays", "5000");
    SetParam(p, "plan-rays", "0");
    EXPECT_LT(p.vertexGatherCost, 0.0f);  // the device's default
    SetParam(p, "vertex-gather", "0");
    EXPECT_EQ(p.vertexGatherCost, 0.0f);
    EXPECT_EQ(p.threads, 3u);
    EXPECT_EQ(p.taskRays, 5000u);
    EXPECT_EQ(p.planRays, 0u);
    EXPECT_EQ(p.minRays, 8u);
    EXPECT_EQ(p.minCandidates, 0u);
    EXPECT_EQ(p.lightMinCandidates, 3u);
    EXPECT_EQ(p.splitsPerList, 2);
    EXPECT_EQ(p.splitRule, SplitRule::kMedian);
    EXPECT_FLOAT_EQ(p.minOriginFraction, 0.001f);
    EXPECT_FLOAT_EQ(p.minDirFraction, 1e-5f);
    EXPECT_FLOAT_EQ(p.dirWeight, 0.5f);
    SetParam(p, "split", "midpoint");
    EXPECT_EQ(p.splitRule, SplitRule::kMidpoint);
}

std::string MessageOf(const std::string& name, const std::string& value) {
    Params p;
    try {
        SetParam(p, name, value);
    } catch (const UsageError& e) {
        return e.what();
    }
    return "no error";
}

TEST(SetParam, UnknownNameListsTheValidNames) {
    const std::string m = MessageOf("min-ray", "8");
    EXPECT_NE(m.find("unknown classify parameter 'min-ray'"), std::string::npos) << m;
    for (const char* name : {"min-rays", "min-candidates", "splits-per-list", "split",
                             "min-origin-fraction", "min-dir-fraction"}) {
        EXPECT_NE(m.find(name), std::string::npos) << name << " missing from: " << m;
    }
}

TEST(SetParam, LightCellsIsAutoOffOrAPowerOfTwoFrom4To256) {
    Params p;
    EXPECT_EQ(p.lightCells, -1);
    SetParam(p, "light-cells", "off");
    EXPECT_EQ(p.lightCells, 0);
    SetParam(p, "light-cells", "256");
    EXPECT_EQ(p.lightCells, 256);
    SetParam(p, "light-cells", "4");
    EXPECT_EQ(p.lightCells, 4);
    SetParam(p, "light-cells", "auto");
    EXPECT_EQ(p.lightCells, -1);
    for (const char* v : {"0", "2", "48", "512", "-4", "+64", "64x", "", "on"}) {
        EXPECT_EQ(MessageOf("light-cells", v),
                  std::string("classify parameter light-cells=") + v +
                      ": expected auto, off or a power of two from 4 to 256");
    }
}

TEST(SetParam, VertexGatherIsANonNegativeNumber) {
    EXPECT_EQ(MessageOf("vertex-gather", "-1"),
              "classify parameter vertex-gather=-1: expected a number >= 0");
    EXPECT_EQ(MessageOf("vertex-gather", "x"),
              "classify parameter vertex-gather=x: expected a number >= 0");
    EXPECT_EQ(MessageOf("vertex-gather", "12.5"), "no error");
}

TEST(SetParam, RejectsValuesThatDoNotParseOrAreOutOfRange) {
    EXPECT_NE(MessageOf("min-rays", "").find("min-rays=: expected an integer >= 0"),
              std::string::npos);
    for (const char* v : {"", "x", "8x", "-1", "1.5", "99999999999"}) {
        EXPECT_THROW({ Params p; SetParam(p, "min-rays", v); }, UsageError) << v;
    }
    EXPECT_THROW({ Params p; SetParam(p, "splits-per-list", "0"); }, UsageError);
    const std::string split = MessageOf("split", "mean");
    EXPECT_NE(split.find("expected midpoint or median"), std::string::npos) << split;
    for (const char* v : {"-0.1", "1.5", "nan", "inf", "", "0.5x"}) {
        EXPECT_THROW({ Params p; SetParam(p, "min-origin-fraction", v); }, UsageError) << v;
        EXPECT_THROW({ Params p; SetParam(p, "min-dir-fraction", v); }, UsageError) << v;
    }
    EXPECT_THROW({ Params p; SetParam(p, "dir-weight", "0"); }, UsageError);
    // A failed call leaves the parameter as it was.
    Params p;
    const uint32_t before = p.minRays;
    EXPECT_THROW(SetParam(p, "min-rays", "abc"), UsageError);
    EXPECT_EQ(p.minRays, before);
}

}  // namespace
}  // namespace rayclass::classify
