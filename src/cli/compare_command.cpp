#include "rayclass/cli/compare_command.h"

#include <charconv>
#include <cmath>
#include <optional>
#include <string_view>
#include <utility>

#include "rayclass/cli/option_table.h"
#include "rayclass/core/error.h"
#include "rayclass/image/compare.h"
#include "rayclass/image/image.h"

namespace rayclass::cli {

namespace {

constexpr std::string_view kUsageHead =
    "usage: rayclass compare A B [--max-rmse X] [--max-id-mismatch FRACTION] [--json]\n"
    "\n"
    "Compares two images (OpenEXR, or PNG decoded to linear) over their R, G and B values and\n"
    "prints mean_abs_error, rmse, psnr_db (peak 1.0, inf when identical) and max_abs_error, plus\n"
    "id_mismatch_pixels and id_mismatch_fraction when both images carry an id layer.\n"
    "\n";

constexpr std::string_view kUsageTail =
    "\n"
    "Exit status: 0 within the bounds, 1 a bound exceeded or the sizes differ, 2 bad arguments\n"
    "or an unreadable image.\n";

struct Options {
    std::vector<std::string> files;
    std::optional<double> maxRmse;
    std::optional<double> maxIdMismatch;
    bool json = false;
    bool help = false;
};

// Shortest text that reads back as the same double, so printed values are exact.
std::string FormatNumber(double value) {
    char buffer[64];
    auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
    return std::string(buffer, result.ptr);
}

double ParseBound(const std::string& option, const std::string& text) {
    double value = 0.0;
    const char* end = text.data() + text.size();
    auto result = std::from_chars(text.data(), end, value);
    if (result.ec != std::errc() || result.ptr != end || !(value >= 0.0) || std::isinf(value)) {
        throw UsageError(option + " needs a non-negative number, got '" + text + "'");
    }
    return value;
}

OptionTable CompareOptionTable(Options& o) {
    return OptionTable(
        {
            {{"--max-rmse"},
             "X",
             "exit 1 when rmse exceeds X",
             [&o](const std::string& opt, const std::string& v) {
                 o.maxRmse = ParseBound(opt, v);
             }},
            {{"--max-id-mismatch"},
             "FRACTION",
             "exit 1 when a larger fraction of pixels have different ids",
             [&o](const std::string& opt, const std::string& v) {
                 o.maxIdMismatch = ParseBound(opt, v);
             }},
            {{"--json"},
             "",
             "print one JSON object instead (infinite values as null)",
             Flag(o.json)},
            {{"--help"}, "", "print this help", Flag(o.help), {"-h"}},
        },
        "", /*dashIsOperand=*/true);
}

Options ParseArgs(const std::vector<std::string>& args) {
    Options options;
    CompareOptionTable(options).Parse(
        args, [&options](const std::string& file) { options.files.push_back(file); });
    if (!options.help && options.files.size() != 2) {
        throw UsageError("expected two image files, got " + std::to_string(options.files.size()));
    }
    return options;
}

void PrintMetrics(const image::ImageComparison& result, bool json, std::ostream& out) {
    // Pixel counts stay exact as doubles up to 2^53 and print without a fraction.
    std::vector<std::pair<const char*, double>> fields = {
        {"mean_abs_error", result.meanAbsError},
        {"rmse", result.rmse},
        {"psnr_db", result.psnrDb},
        {"max_abs_error", result.maxAbsError},
    };
    if (result.hasIds) {
        fields.emplace_back("id_mismatch_pixels", double(result.idMismatchPixels));
        fields.emplace_back("id_mismatch_fraction", result.idMismatchFraction);
    }
    if (!json) {
        for (const auto& [key, value] : fields) out << key << ": " << FormatNumber(value) << "\n";
        return;
    }
    out << "{";
    for (size_t i = 0; i < fields.size(); ++i) {
        const auto& [key, value] = fields[i];
        // JSON has no inf or nan.
        out << (i ? ", " : "") << "\"" << key
            << "\": " << (std::isfinite(value) ? FormatNumber(value) : "null");
    }
    out << "}\n";
}

}  // namespace

int CompareCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
    Options options;
    try {
        options = ParseArgs(args);
    } catch (const UsageError& e) {
        err << e.what() << "\n"
            << "run 'rayclass compare --help' for usage\n";
        return 2;
    }
    if (options.help) {
        Options unused;
        out << kUsageHead << CompareOptionTable(unused).Help(28) << kUsageTail;
        return 0;
    }
    image::Image a;
    image::Image b;
    try {
        a = image::ReadImage(options.files[0]);
        b = image::ReadImage(options.files[1]);
    } catch (const Error& e) {
        err << e.what() << "\n";
        return 2;
    }
    image::ImageComparison result;
    try {
        result = image::Compare(a, b);
    } catch (const Error& e) {  // the sizes differ
        err << e.what() << "\n";
        return 1;
    }
    if (options.maxIdMismatch && !result.hasIds) {
        const std::string& without = a.id.empty() ? options.files[0] : options.files[1];
        err << "--max-id-mismatch needs an id layer in both images; " << without << " has none\n";
        return 2;
    }
    PrintMetrics(result, options.json, out);
    int status = 0;
    if (options.maxRmse && !(result.rmse <= *options.maxRmse)) {
        err << "rmse " << FormatNumber(result.rmse) << " exceeds --max-rmse "
            << FormatNumber(*options.maxRmse) << "\n";
        status = 1;
    }
    if (options.maxIdMismatch && !(result.idMismatchFraction <= *options.maxIdMismatch)) {
        err << "id_mismatch_fraction " << FormatNumber(result.idMismatchFraction)
            << " exceeds --max-id-mismatch " << FormatNumber(*options.maxIdMismatch) << "\n";
        status = 1;
    }
    return status;
}

}  // namespace rayclass::cli
