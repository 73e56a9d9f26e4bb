#include "rayclass/cli/cli.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iostream>

#include "rayclass/cli/compare_command.h"
#include "rayclass/core/error.h"

namespace rayclass::cli {

namespace {

constexpr const char* kUsage = R"(usage: rayclass <command> [options]

commands:
  render SCENE -o OUT.{exr,png} [options]   render a JSON scene or a bare OBJ
  merge -o OUT.{exr,png} TILE.exr...        put the tiles of a render together
  compare A.exr B.exr [options]             error statistics between two images
  devices                                   list OpenCL platforms and devices
  classify-stats SCENE [options]            ray-classification statistics of a scene

'rayclass <command> --help' describes a command's options.
  --help       this text
  --version    the version
)";

}  // namespace

namespace {

int Dispatch(const std::string& command, const std::vector<std::string>& rest) {
    try {
        if (command == "--help" || command == "-h" || command == "help") {
            std::cout << kUsage;
            return 0;
        }
        if (command == "--version") {
            std::cout << "rayclass " << RAYCLASS_VERSION << "\n";
            return 0;
        }
        if (command == "render") return RenderCommand(rest, std::cout, std::cerr);
        if (command == "merge") return MergeCommand(rest, std::cout, std::cerr);
        if (command == "compare") return CompareCommand(rest, std::cout, std::cerr);
        if (command == "devices") return DevicesCommand(rest, std::cout, std::cerr);
        if (command == "classify-stats") return ClassifyStatsCommand(rest, std::cout, std::cerr);
        std::cerr << "rayclass: unknown command '" << command << "'\n\n" << kUsage;
        return 2;
    } catch (const UsageError& e) {
        std::cerr << "rayclass " << command << ": " << e.what() << "\n";
        return 2;
    } catch (const std::exception& e) {
        std::cerr << "rayclass " << command << ": error: " << e.what() << "\n";
        return 1;
    }
}

}  // namespace

int Main(int argc, char** argv) {
    // A write error's errno is lost once the stream has failed: a buffer larger than any help
    // text or report keeps the one write of a command's output in the final flush below, which
    // can then name the error.
    static char stdoutBuffer[1 << 16];
    std::setvbuf(stdout, stdoutBuffer, _IOFBF, sizeof stdoutBuffer);
    std::vector<std::string> args(argv + 1, argv + argc);
    if (args.empty()) {
        std::cerr << kUsage;
        return 2;
    }
    const std::string command = args.front();
    const int status = Dispatch(command, std::vector<std::string>(args.begin() + 1, args.end()));
    // What a command prints on stdout is output too (compare --json, classify-stats --json, often
    // redirected to a file): a full disk there must not exit 0. Buffered text fails only here.
    errno = 0;
    if (!std::cout.flush()) {
        std::cerr << "rayclass " << command
                  << ": error: standard output: " << std::strerror(errno != 0 ? errno : EIO)
                  << "\n";
        return 1;
    }
    return status;
}

}  // namespace rayclass::cli
