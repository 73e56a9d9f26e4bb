// `rayclass merge`: tiles of one render (rayclass render --tile / --crop) into the whole image.
#include <string>
#include <vector>

#include "rayclass/cli/cli.h"
#include "rayclass/cli/option_table.h"
#include "rayclass/core/error.h"
#include "rayclass/image/image.h"
#include "rayclass/image/merge.h"

namespace rayclass::cli {

namespace {

constexpr const char* kUsageHead =
    R"(usage: rayclass merge -o OUT.{exr,png} TILE.exr... [--allow-partial]

Puts the tiles or crops of one render (rayclass render --tile I/N or --crop) together into the
whole image, every layer in its place. Refuses, writing nothing, tiles of different images
(display windows, layers or scene hashes), overlapping tiles, and pixels no tile covers.

options:
)";

struct MergeArgs {
    std::string output;
    std::vector<std::string> tiles;
    bool allowPartial = false;
    bool help = false;
};

OptionTable MergeOptionTable(MergeArgs& m) {
    return OptionTable(
        {
            {{"-o", "--output"},
             "FILE",
             "the merged image: .exr (every layer) or .png",
             Text(m.output)},
            {{"--allow-partial"},
             "",
             "merge even where no tile covers some pixels (black, layers of misses)",
             Flag(m.allowPartial)},
            {{"--help"}, "", "print this help", Flag(m.help), {"-h"}, true},
        },
        " (see 'rayclass merge --help')");
}

}  // namespace

int MergeCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream&) {
    MergeArgs m;
    MergeOptionTable(m).Parse(args, [&m](const std::string& a) { m.tiles.push_back(a); });
    if (m.help) {
        MergeArgs unused;
        out << kUsageHead << MergeOptionTable(unused).Help(24);
        return 0;
    }
    if (m.output.empty()) throw UsageError("no output given: -o OUT.exr or -o OUT.png");
    if (m.tiles.empty()) throw UsageError("no tiles given (see 'rayclass merge --help')");
    std::vector<image::NamedTile> tiles;
    for (const std::string& file : m.tiles) tiles.push_back({file, image::ReadImage(file)});
    image::WriteImage(image::MergeTiles(tiles, m.allowPartial), m.output);
    return 0;
}

}  // namespace rayclass::cli
