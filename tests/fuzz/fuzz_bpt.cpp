// libFuzzer target: a .bpt patch file (Bezier nets, scene/patch.h ParseBpt) read through the
// scene loader as a bezier object's "file", the way a scene names one, so the bytes pass
// ReadFile, ParseBpt, degree elevation and the split into patch boxes. Only SceneError may
// leave the loader; anything else (another exception, a crash, a sanitizer report) is a finding.
// The loader must agree with ParseBpt on the same bytes (the same error, or as many patches),
// and every patch's boxes must cover its parameter square exactly and hold its corners, which
// lie on the surface.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "rayclass/core/error.h"
#include "rayclass/scene/loader.h"
#include "rayclass/scene/patch.h"

namespace {

namespace scene = rayclass::scene;

const std::filesystem::path& InputPath() {
    static const std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("rayclass-fuzz-bpt-" + std::to_string(getpid()));
    return path;
}

void WriteInput(const uint8_t* data, size_t size) {
    std::FILE* f = std::fopen(InputPath().c_str(), "wb");
    if (!f) std::abort();
    if (size && std::fwrite(data, 1, size, f) != size) std::abort();
    if (std::fclose(f) != 0) std::abort();
}

// The scene that names the input as its only object's patch file.
std::string SceneText() {
    return R"({"camera": {"position": [0, 0, 10], "look_at": [0, 0, 0]},
               "objects": [{"type": "bezier", "file": ")" +
           InputPath().string() + R"("}]})";
}

// Each patch's boxes: parameter rectangles of total area 1 (halvings are exact in double),
// whose bounds hold the patch's four corner points.
void CheckBoxes(const scene::Scene& s) {
    std::vector<double> area(s.patches.size(), 0.0);
    std::vector<int> corners(s.patches.size(), 0);
    for (const scene::PatchBox& box : s.patchBoxes) {
        if (box.patch >= s.patches.size()) std::abort();
        area[box.patch] += (box.u.y - box.u.x) * (box.v.y - box.v.x);
        const auto& p = s.patches[box.patch].p;
        const int corner[4] = {0, 3, 12, 15};
        for (int c = 0; c < 4; ++c) {
            const glm::dvec4& h = p[size_t(corner[c])];
            if (box.bounds.Contains(glm::vec3(glm::dvec3(h) / h.w))) corners[box.patch] |= 1 << c;
        }
    }
    for (size_t k = 0; k < s.patches.size(); ++k) {
        if (area[k] != 1.0 || corners[k] != 15) std::abort();
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    WriteInput(data, size);
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    std::string parsed;
    size_t nets = 0;
    try {
        nets = scene::ParseBpt(text, InputPath()).size();
    } catch (const rayclass::SceneError& e) {
        parsed = e.what();
    }
    try {
        const scene::Scene s =
            scene::LoadSceneText(SceneText(), RAYCLASS_FUZZ_MESH_DIR "/fuzz.json");
        if (!parsed.empty() || s.patches.size() != nets) std::abort();
        CheckBoxes(s);
    } catch (const rayclass::SceneError& e) {
        if (parsed != e.what()) std::abort();
    }
    return 0;
}
