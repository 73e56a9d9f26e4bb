// The option table on its own: parsing in order, operands, values, unknown options, and the help
// rows it prints from the same entries.
#include "rayclass/cli/option_table.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace rayclass::cli {
namespace {

enum class Fruit { kApple, kPear, kPlum };
constexpr render::Named<Fruit> kFruits[] = {
    {"apple", Fruit::kApple}, {"pear", Fruit::kPear}, {"plum", Fruit::kPlum}};

struct Args {
    std::vector<std::string> operands, seen;
    Fruit fruit = Fruit::kApple;
    bool flag = false, help = false;
};

OptionTable Table(Args& a, bool dashIsOperand = false) {
    return OptionTable(
        {
            {{"-f", "--fruit"}, "F", "a fruit: apple, pear or plum", Choice(a.fruit, kFruits)},
            {{"--x"},
             "X",
             "",
             [&a](const std::string& o, const std::string& v) { a.seen.push_back(o + "=" + v); }},
            {{"--y"},
             "Y",
             "two values\nthat share a row",
             [&a](const std::string& o, const std::string& v) { a.seen.push_back(o + "=" + v); }},
            {{"--flag"},
             "",
             "a flag",
             [&a](const std::string&, const std::string&) { a.flag = true; }},
            {{},
             "",
             "",
             [&a](const std::string&, const std::string&) { a.help = true; },
             {"--help"},
             /*ends=*/true},
        },
        " (see --help)", dashIsOperand);
}

std::string MessageOf(const std::vector<std::string>& args, bool dashIsOperand = false) {
    Args a;
    try {
        Table(a, dashIsOperand).Parse(args, [&a](const std::string& s) {
            a.operands.push_back(s);
        });
    } catch (const UsageError& e) {
        return e.what();
    }
    return "no error";
}

TEST(OptionTable, AppliesOptionsInOrderAndPassesOperandsOn) {
    Args a;
    Table(a).Parse({"in", "--x", "1", "--fruit", "plum", "--y", "-2", "--flag", "", "out"},
                   [&a](const std::string& s) { a.operands.push_back(s); });
    EXPECT_EQ(a.operands, (std::vector<std::string>{"in", "", "out"}));
    EXPECT_EQ(a.seen, (std::vector<std::string>{"--x=1", "--y=-2"}));
    EXPECT_EQ(a.fruit, Fruit::kPlum);
    EXPECT_TRUE(a.flag);
}

TEST(OptionTable, AnEndingOptionLeavesTheRestUnread) {
    Args a;
    Table(a).Parse({"--help", "--bogus"}, [](const std::string&) {});
    EXPECT_TRUE(a.help);
    EXPECT_EQ(MessageOf({"--bogus", "--help"}), "unknown option '--bogus' (see --help)");
}

TEST(OptionTable, UsageErrorsNameTheOption) {
    EXPECT_EQ(MessageOf({"--x"}), "--x needs a value");
    EXPECT_EQ(MessageOf({"-f", "fig"}), "-f must be apple, pear or plum, not 'fig'");
    EXPECT_EQ(MessageOf({"-"}), "unknown option '-' (see --help)");
    EXPECT_EQ(MessageOf({"-"}, /*dashIsOperand=*/true), "no error");
}

TEST(OptionTable, HelpHasARowPerOptionFromTheSameTable) {
    Args a;
    EXPECT_EQ(Table(a).Help(14),
              "  -f, --fruit F a fruit: apple, pear or plum\n"
              "  --x X, --y Y  two values\n"
              "                that share a row\n"
              "  --flag        a flag\n");
}

TEST(OptionTable, NumbersMustParseWhollyWithinTheirRange) {
    EXPECT_EQ(ParseNumber<int>("--n", "12", 1, 16), 12);
    for (const char* text : {"0", "17", "12x", "", "-1"}) {
        EXPECT_THROW(ParseNumber<int>("--n", text, 1, 16), UsageError) << text;
    }
    try {
        ParseNumber<unsigned>("--n", "x", 1, 100, "an integer");
        FAIL();
    } catch (const UsageError& e) {
        EXPECT_STREQ(e.what(), "--n expects an integer in [1, 100], not 'x'");
    }
}

TEST(OptionTable, NameValueSplitsAtTheFirstEqualsSign) {
    EXPECT_EQ(NameValue("--c", "a=b=c"), (std::pair<std::string, std::string>{"a", "b=c"}));
    EXPECT_THROW(NameValue("--c", "ab"), UsageError);
}

}  // namespace
}  // namespace rayclass::cli
