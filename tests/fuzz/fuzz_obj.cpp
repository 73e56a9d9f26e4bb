// libFuzzer target: the OBJ and MTL parsers on in-memory text. The OBJ is parsed as if it were
// tests/fuzz/mesh/fuzz.obj, so `mtllib tri.mtl` reaches a real library. Only SceneError may
// leave the parsers; anything else (another exception, a crash, a sanitizer report) is a finding.
// The OBJ is parsed whole and in 2 to 5 pieces on threads: a different mesh or message is a
// finding too.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

#include "rayclass/core/error.h"
#include "rayclass/scene/obj.h"

namespace {

// The mesh's bytes and names, or the error: equal for equal outcomes.
std::string Outcome(std::string_view text, size_t pieces) {
    try {
        const rayclass::scene::ObjMesh m =
            rayclass::scene::ParseObj(text, RAYCLASS_FUZZ_MESH_DIR "/fuzz.obj", pieces);
        std::string out;
        auto bytes = [&](const auto& v) {
            out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(v[0]));
            out.push_back('|');
        };
        bytes(m.positions);
        bytes(m.normals);
        bytes(m.texcoords);
        bytes(m.triangles);
        for (const std::string& g : m.groups) out.append(g).push_back('|');
        for (const auto& material : m.materials) out.append(material.name).push_back('|');
        return out;
    } catch (const rayclass::SceneError& e) {
        return std::string("error: ") + e.what();
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    const std::string whole = Outcome(text, 1);
    if (Outcome(text, 2 + size % 4) != whole) std::abort();
    try {
        rayclass::scene::ParseMtl(text, RAYCLASS_FUZZ_MESH_DIR "/fuzz.mtl");
    } catch (const rayclass::SceneError&) {
    }
    return 0;
}
