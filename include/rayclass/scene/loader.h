// Scene input: JSON scene files and bare Wavefront OBJ meshes (see README "Scene format").
#pragma once

#include <filesystem>
#include <string_view>

#include "rayclass/scene/scene.h"

namespace rayclass::scene {

// Loads `file` by extension: ".json" is a scene file, ".obj" a bare mesh rendered with a framing
// camera, one light at the camera and the mesh's own MTL materials (else the default material).
// Throws SceneError naming the file, the line and the problem.
Scene LoadScene(const std::filesystem::path& file);

// Parses JSON scene text as if read from `file` (which names it in errors and anchors the
// relative paths of its meshes). Throws SceneError.
Scene LoadSceneText(std::string_view text, const std::filesystem::path& file);

}  // namespace rayclass::scene
