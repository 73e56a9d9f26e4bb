// scripts/bench's silhouette measure: the share of pixels whose first hit lies on another object
// (by name; a miss is none) in two renders of possibly different scenes, e.g. the teapot as
// patches and as triangles. Primitive ids cannot be compared across scenes; object names can.
//
// usage: object_mismatch SCENE_A A.exr SCENE_B B.exr [--patch-boxes N]
// Both images need the id AOV; --patch-boxes N splits both scenes' patches as the renders did.
// Prints the mismatching share of the pixels.
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "rayclass/image/image.h"
#include "rayclass/scene/loader.h"
#include "rayclass/scene/patch.h"

namespace {

using namespace rayclass;

// The object index of every global primitive id of `s`.
std::vector<uint32_t> ObjectOfPrimitive(const scene::Scene& s) {
    std::vector<uint32_t> out;
    for (const auto& t : s.triangles) out.push_back(t.object);
    for (const auto& p : s.spheres) out.push_back(p.object);
    for (const auto& q : s.quadrics) out.push_back(q.object);
    for (const auto& b : s.patchBoxes) out.push_back(s.patches[b.patch].object);
    return out;
}

std::vector<std::string> ObjectNames(const std::string& scenePath, const std::string& imagePath,
                                     uint32_t boxes) {
    scene::Scene s = scene::LoadScene(scenePath);
    if (boxes) scene::SplitPatches(s, {s.patchFlatness, boxes});
    const image::Image img = image::ReadImage(imagePath);
    if (img.id.empty()) throw std::runtime_error(imagePath + " has no id layer (--aov id)");
    const std::vector<uint32_t> object = ObjectOfPrimitive(s);
    std::vector<std::string> names;
    names.reserve(img.id.size());
    for (uint32_t id : img.id) {
        if (id == 0xFFFFFFFFu) {
            names.emplace_back();
        } else if (id >= object.size()) {
            throw std::runtime_error(imagePath + ": id " + std::to_string(id) + " not in " +
                                     scenePath);
        } else {
            names.push_back(s.objects[object[id]].name);
        }
    }
    return names;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 5 && !(argc == 7 && std::string(argv[5]) == "--patch-boxes")) {
        std::fprintf(stderr,
                     "usage: object_mismatch SCENE_A A.exr SCENE_B B.exr [--patch-boxes N]\n");
        return 2;
    }
    try {
        const uint32_t boxes = argc == 7 ? uint32_t(std::atoi(argv[6])) : 0;
        const auto a = ObjectNames(argv[1], argv[2], boxes);
        const auto b = ObjectNames(argv[3], argv[4], boxes);
        if (a.size() != b.size()) throw std::runtime_error("the images differ in size");
        size_t differ = 0;
        for (size_t i = 0; i < a.size(); ++i) differ += a[i] != b[i];
        std::printf("%.9g\n", double(differ) / double(a.size()));
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "object_mismatch: %s\n", e.what());
        return 1;
    }
}
