// scripts/bench's tessellations: the patches of one object of a scene as an OBJ mesh of the
// project's tessellator (scene/tessellate.h), in world space with vertex normals.
//
// usage: tessellate_patches SCENE.json OBJECT N OUT.obj
// Prints the triangle count. OUT.obj is written to a temporary name and renamed.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "rayclass/scene/loader.h"
#include "rayclass/scene/tessellate.h"

namespace {

using namespace rayclass;

int Run(const std::string& scenePath, const std::string& object, uint32_t n,
        const std::filesystem::path& out) {
    const scene::Scene s = scene::LoadScene(scenePath);
    const std::filesystem::path tmp = out.string() + ".tmp";
    std::ofstream f(tmp);
    f << "# " << object << " of " << scenePath << ", " << n << "x" << n
      << " quads a patch (tessellate_patches)\n";
    f.precision(9);
    size_t triangles = 0;
    for (const scene::Patch& patch : s.patches) {
        if (s.objects[patch.object].name != object) continue;
        for (const scene::Triangle& t : scene::TessellatePatch(patch, n)) {
            for (int k = 0; k < 3; ++k)
                f << "v " << t.p[k].x << " " << t.p[k].y << " " << t.p[k].z << "\n";
            for (int k = 0; k < 3; ++k)
                f << "vn " << t.n[k].x << " " << t.n[k].y << " " << t.n[k].z << "\n";
            const size_t b = 3 * triangles + 1;
            if (t.hasNormals) {
                f << "f " << b << "//" << b << " " << b + 1 << "//" << b + 1 << " " << b + 2 << "//"
                  << b + 2 << "\n";
            } else {
                f << "f " << b << " " << b + 1 << " " << b + 2 << "\n";
            }
            ++triangles;
        }
    }
    f.close();
    if (!f || triangles == 0) {
        std::filesystem::remove(tmp);
        std::fprintf(stderr, "tessellate_patches: %s: %s\n", scenePath.c_str(),
                     triangles ? "cannot write the mesh" : "no patches of that object");
        return 1;
    }
    std::filesystem::rename(tmp, out);
    std::printf("%zu\n", triangles);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 5 || std::atoi(argv[3]) < 1) {
        std::fprintf(stderr, "usage: tessellate_patches SCENE.json OBJECT N OUT.obj\n");
        return 2;
    }
    try {
        return Run(argv[1], argv[2], uint32_t(std::atoi(argv[3])), argv[4]);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "tessellate_patches: %s\n", e.what());
        return 1;
    }
}
