// Fixture files for the scene tests: a private temporary directory and the repository's scenes.
#pragma once

#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <string_view>

#include "rayclass/core/error.h"

namespace rayclass::scene::testing {

// A directory under the system temp dir, removed with everything in it at the end of the test.
class TempDir {
  public:
    TempDir() {
        static std::atomic<int> counter{0};
        path_ =
            std::filesystem::temp_directory_path() /
            ("rayclass_scene_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
        std::filesystem::remove_all(path_);
        std::filesystem::create_directories(path_);
    }
    ~TempDir() {
        std::error_code ignored;
        std::filesystem::remove_all(path_, ignored);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;

    const std::filesystem::path& path() const { return path_; }

    // Writes `text` byte for byte (no newline translation) to `name`, creating folders.
    std::filesystem::path Write(const std::string& name, std::string_view text) const {
        const std::filesystem::path file = path_ / name;
        std::filesystem::create_directories(file.parent_path());
        std::ofstream out(file, std::ios::binary);
        out.write(text.data(), std::streamsize(text.size()));
        return file;
    }

  private:
    std::filesystem::path path_;
};

// The repository's scenes/: under RAYCLASS_SOURCE_DIR (set by every suite's main), else under the
// source tree this file lives in (tests/scene/ -> project root).
inline std::filesystem::path ScenesDir() {
    if (const char* source = std::getenv("RAYCLASS_SOURCE_DIR")) {
        return std::filesystem::path(source) / "scenes";
    }
    return std::filesystem::path(__FILE__).parent_path() / ".." / ".." / "scenes";
}

// what() of the SceneError that `f` throws, or a note that it threw none.
inline std::string ErrorOf(const std::function<void()>& f) {
    try {
        f();
    } catch (const SceneError& e) {
        return e.what();
    }
    return "no SceneError";
}

}  // namespace rayclass::scene::testing
