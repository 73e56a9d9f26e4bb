// The render program compiles without a warning under each of its build variants: PoCL's
// compiler prints a warning to the command's standard error on every fresh build, where a user
// reads it as rayclass's, and another vendor's compiler may reject what only warns here.
#include <gtest/gtest.h>

#include <exception>
#include <ostream>
#include <string>

#include "rayclass/clrt/context.h"
#include "rayclass/render/launch.h"
#include "test_device.h"

namespace rayclass::render {
namespace {

clrt::Context& SharedContext() {
    static clrt::Context ctx(TestDeviceSpec());
    return ctx;
}

struct Variant {
    std::string name;
    std::string options;  // FrameBuildOptions' defines for the variant
};
void PrintTo(const Variant& v, std::ostream* os) { *os << v.name; }

// One test per variant, so that a cold program cache compiles them in parallel runs.
class RenderProgramVariant : public ::testing::TestWithParam<Variant> {};

TEST_P(RenderProgramVariant, CompilesWithoutWarnings) {
    // -Werror (an OpenCL build option) turns a warning into a build error, whose message
    // carries the build log.
    try {
        BuildRenderProgram(SharedContext(), "-Werror " + GetParam().options);
    } catch (const std::exception& e) {
        ADD_FAILURE() << e.what();
    }
}

INSTANTIATE_TEST_SUITE_P(Variants, RenderProgramVariant,
                         ::testing::Values(Variant{"default", ""},
                                           Variant{"polar16", "-DRC_POLAR16"},
                                           Variant{"watertight", "-DRC_WATERTIGHT=1"}),
                         [](const auto& info) { return info.param.name; });

}  // namespace
}  // namespace rayclass::render
