// The rayclass command line: render, merge, compare, devices, classify-stats. Main is the single
// place where errors become a message on stderr and an exit status.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace rayclass::cli {

int Main(int argc, char** argv);

// The commands, for tests: args exclude the program and command names.
int RenderCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int ClassifyStatsCommand(const std::vector<std::string>& args, std::ostream& out,
                         std::ostream& err);
int MergeCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int DevicesCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace rayclass::cli
