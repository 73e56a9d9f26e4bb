// libFuzzer target: the JSON scene loader on in-memory text (LoadSceneText), as if the scene were
// tests/fuzz/mesh/fuzz.json, so `"file": "tri.obj"` loads a real mesh through the whole path
// (transform, materials, bounds, camera). Only SceneError may leave the loader.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "rayclass/core/error.h"
#include "rayclass/scene/loader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    try {
        rayclass::scene::LoadSceneText(text, RAYCLASS_FUZZ_MESH_DIR "/fuzz.json");
    } catch (const rayclass::SceneError&) {
    }
    return 0;
}
