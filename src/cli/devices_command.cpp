#include <ostream>

#include "rayclass/cli/cli.h"
#include "rayclass/clrt/context.h"
#include "rayclass/core/error.h"

namespace rayclass::cli {

int DevicesCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
    if (!args.empty() && (args[0] == "--help" || args[0] == "-h")) {
        out << "usage: rayclass devices\n\nLists every OpenCL device with the index that "
               "'render --device INDEX' takes.\n";
        return 0;
    }
    if (!args.empty()) throw UsageError("unexpected argument '" + args[0] + "'");
    const auto devices = clrt::ListDevices();
    if (devices.empty()) {
        err << "no OpenCL device found (is an ICD such as pocl-opencl-icd installed?)\n";
        return 1;
    }
    for (const auto& d : devices) {
        out << d.index << ": " << d.name << " [" << d.type << "]\n"
            << "   platform: " << d.platform << "\n"
            << "   version: " << d.version << ", compute units: " << d.computeUnits
            << ", global memory: " << (d.globalMemBytes >> 20)
            << " MiB, max allocation: " << (d.maxAllocBytes >> 20) << " MiB\n";
    }
    return 0;
}

}  // namespace rayclass::cli
