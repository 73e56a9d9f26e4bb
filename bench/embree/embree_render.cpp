// The Embree Whitted renderer (whitted.h) as a command, the whole-frame peer of `rayclass
// render` in scripts/yardstick:
//   embree_render SCENE -o OUT.{exr,png} [--width W] [--height H] [--max-depth N]
//                 [--min-weight W] [--threads N] [--stats FILE.json]
// It loads the scene and writes the image with rayclass's own loader and writer (same defaults),
// so the two commands differ only in how the frame is traced. --stats writes the stage times
// (scene_load, bvh_build, trace, total up to the image write) and the rays traced per kind.
// Exit status: 0 success, 1 failure (the message names the file and problem), 2 wrong usage.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>

#include "rayclass/image/image.h"
#include "rayclass/scene/loader.h"
#include "whitted.h"

using namespace rayclass;

namespace {

struct UsageError : std::invalid_argument {
    using std::invalid_argument::invalid_argument;
};

struct Args {
    std::string scene, output, stats;
    uint32_t width = 0, height = 0;
    bench::WhittedOptions options;
};

template <typename T>
T Number(const std::string& option, const std::string& v) {
    try {
        size_t used = 0;
        const double x = std::stod(v, &used);
        if (used == v.size() && x >= 0) return T(x);
    } catch (const std::exception&) {
    }
    throw UsageError(option + " needs a non-negative number, not '" + v + "'");
}

Args ParseArgs(int argc, char** argv) {
    Args a;
    const std::map<std::string, std::function<void(const std::string&)>> options{
        {"-o", [&a](const std::string& v) { a.output = v; }},
        {"--output", [&a](const std::string& v) { a.output = v; }},
        {"--stats", [&a](const std::string& v) { a.stats = v; }},
        {"--width", [&a](const std::string& v) { a.width = Number<uint32_t>("--width", v); }},
        {"--height", [&a](const std::string& v) { a.height = Number<uint32_t>("--height", v); }},
        {"--max-depth",
         [&a](const std::string& v) { a.options.maxDepth = Number<uint32_t>("--max-depth", v); }},
        {"--min-weight",
         [&a](const std::string& v) { a.options.minWeight = Number<float>("--min-weight", v); }},
        {"--threads",
         [&a](const std::string& v) { a.options.threads = Number<int>("--threads", v); }}};
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        const auto option = options.find(arg);
        if (option == options.end()) {
            if (arg[0] == '-' || !a.scene.empty()) throw UsageError("unexpected argument " + arg);
            a.scene = arg;
            continue;
        }
        if (i + 1 >= argc) throw UsageError(arg + " needs a value");
        option->second(argv[++i]);
    }
    if (a.scene.empty() || a.output.empty()) throw UsageError("a scene and -o OUT are required");
    return a;
}

double Since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Writes `text` to `file` through a temporary name, so a failure leaves no partial file.
void WriteAtomically(const std::filesystem::path& file, const std::string& text) {
    const std::filesystem::path tmp = file.string() + ".tmp";
    {
        std::ofstream f(tmp);
        f << text;
        if (!f.flush()) throw std::runtime_error("cannot write " + tmp.string());
    }
    std::filesystem::rename(tmp, file);
}

}  // namespace

int main(int argc, char** argv) {
    Args a;
    try {
        a = ParseArgs(argc, argv);
    } catch (const UsageError& e) {
        std::fprintf(stderr,
                     "embree_render: %s\nusage: embree_render SCENE -o OUT.{exr,png} [--width W] "
                     "[--height H] [--max-depth N] [--min-weight W] [--threads N] "
                     "[--stats FILE.json]\n",
                     e.what());
        return 2;
    }
    try {
        const auto t0 = std::chrono::steady_clock::now();
        scene::Scene sc = scene::LoadScene(a.scene);
        if (a.width) sc.camera.width = a.width;
        if (a.height) sc.camera.height = a.height;
        const double loadS = Since(t0);
        bench::WhittedStats stats;
        const image::Image img = bench::RenderWhitted(sc, a.options, stats);
        const double totalS = Since(t0);
        if (!a.stats.empty()) {
            char json[512];
            std::snprintf(json, sizeof json,
                          "{\"time_s\": {\"scene_load\": %.6g, \"bvh_build\": %.6g, "
                          "\"trace\": %.6g, \"total\": %.6g}, \"rays_by_kind\": {\"eye\": %llu, "
                          "\"shadow\": %llu, \"reflection\": %llu, \"refraction\": %llu}}\n",
                          loadS, stats.buildSeconds, stats.traceSeconds, totalS,
                          (unsigned long long)stats.eye, (unsigned long long)stats.shadow,
                          (unsigned long long)stats.reflection,
                          (unsigned long long)stats.refraction);
            WriteAtomically(a.stats, json);
        }
        image::WriteImage(img, a.output);
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "embree_render: %s\n", e.what());
        return 1;
    }
}
