// libFuzzer target: the OBJ and MTL parsers on in-memory text. The OBJ is parsed as if it were
// tests/fuzz/mesh/fuzz.obj, so `mtllib tri.mtl` reaches a real library. Only SceneError may
// leave the parsers; anything else (another exception, a crash, a sanitizer report) is a finding.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "rayclass/core/error.h"
#include "rayclass/scene/obj.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    try {
        rayclass::scene::ParseObj(text, RAYCLASS_FUZZ_MESH_DIR "/fuzz.obj");
    } catch (const rayclass::SceneError&) {
    }
    try {
        rayclass::scene::ParseMtl(text, RAYCLASS_FUZZ_MESH_DIR "/fuzz.mtl");
    } catch (const rayclass::SceneError&) {
    }
    return 0;
}
