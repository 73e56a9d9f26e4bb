#include "rayclass/scene/obj.h"

#include <charconv>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "rayclass/core/error.h"
#include "text_input.h"

namespace rayclass::scene {

namespace {

namespace fs = std::filesystem;

[[noreturn]] void Fail(const fs::path& file, int line, std::string problem) {
    throw SceneError(file.string(), line, std::move(problem));
}

std::string Quoted(std::string_view s) {
    // Appending (rather than "'" + ... + "'") avoids a GCC 12 -Wrestrict false positive.
    std::string quoted(1, '\'');
    quoted.append(s).push_back('\'');
    return quoted;
}

[[noreturn]] void FailNumber(NumberStatus status, std::string_view token, std::string_view keyword,
                             const fs::path& file, int line) {
    const std::string where = " in " + Quoted(keyword) + " statement";
    switch (status) {
        case NumberStatus::kNonFinite:
            Fail(file, line, "non-finite number " + Quoted(token) + where);
        case NumberStatus::kOutOfRange:
            Fail(file, line, "number " + Quoted(token) + " out of range" + where);
        default:
            Fail(file, line, "malformed number " + Quoted(token) + where);
    }
}

// Reads the numbers of a `keyword` statement into `out`: between minCount and maxCount of them.
int ReadNumbers(std::string_view rest, std::string_view keyword, int minCount, int maxCount,
                float* out, const fs::path& file, int line) {
    int count = 0;
    for (std::string_view token = NextToken(rest); !token.empty(); token = NextToken(rest)) {
        if (count < maxCount) {
            const NumberStatus status = ParseFloat(token, out[count]);
            if (status != NumberStatus::kOk) FailNumber(status, token, keyword, file, line);
        }
        ++count;
    }
    if (count < minCount || count > maxCount) {
        const std::string expected =
            minCount == maxCount ? std::to_string(minCount)
                                 : std::to_string(minCount) + " to " + std::to_string(maxCount);
        Fail(file, line,
             "expected " + expected + " numbers in " + Quoted(keyword) + " statement, got " +
                 std::to_string(count));
    }
    return count;
}

// Number whose value the statement restricts (d in [0, 1], Ns >= 0, ...).
[[noreturn]] void FailRange(std::string_view keyword, std::string_view rest, const fs::path& file,
                            int line) {
    Fail(file, line,
         "number " + Quoted(Trim(rest)) + " out of range in " + Quoted(keyword) + " statement");
}

// A colour statement (Kd r [g [b]]): missing components default to r, as the MTL format says.
glm::vec3 ReadColor(std::string_view rest, std::string_view keyword, const fs::path& file,
                    int line) {
    float c[3];
    const int count = ReadNumbers(rest, keyword, 1, 3, c, file, line);
    const glm::vec3 color(c[0], count > 1 ? c[1] : c[0], count > 2 ? c[2] : c[0]);
    if (color.r < 0.0f || color.g < 0.0f || color.b < 0.0f) FailRange(keyword, rest, file, line);
    return color;
}

float ReadScalar(std::string_view rest, std::string_view keyword, const fs::path& file, int line) {
    float value = 0.0f;
    ReadNumbers(rest, keyword, 1, 1, &value, file, line);
    return value;
}

// MTL values before they are mapped onto the Whitted material.
struct MtlEntry {
    Material material;
    float dissolve = 1.0f;
    int illum = 2;
};

Material ToWhitted(const MtlEntry& e) {
    Material m = e.material;
    if (e.illum == 3 || e.illum == 5) m.kr = m.ks;
    const bool glassIllum = e.illum == 4 || e.illum == 6 || e.illum == 7;
    if (glassIllum || e.dissolve < 1.0f)
        m.kt = glm::vec3(e.dissolve < 1.0f ? 1.0f - e.dissolve : 1.0f);
    m.fresnel = glassIllum || e.illum == 5 || e.dissolve < 1.0f;
    return m;
}

class ObjParser {
  public:
    explicit ObjParser(const fs::path& file) : file_(file) {}

    ObjMesh Parse(std::string_view text) {
        LineReader lines(text);
        std::string_view line;
        int number = 0;
        while (lines.Next(line, number)) Statement(line, number);
        ResolveMaterials();
        return std::move(mesh_);
    }

  private:
    struct Corner {
        uint32_t position;
        int32_t texcoord;
        int32_t normal;
    };
    struct UsedMaterial {
        std::string name;
        int line;  // first usemtl naming it
    };

    void Statement(std::string_view line, int number) {
        std::string_view rest = line;
        const std::string_view keyword = NextToken(rest);
        float c[6];
        if (keyword == "v") {
            ReadNumbers(rest, keyword, 3, 6, c, file_, number);
            mesh_.positions.emplace_back(c[0], c[1], c[2]);
        } else if (keyword == "f") {
            Face(rest, number);
        } else if (keyword == "vn") {
            ReadNumbers(rest, keyword, 3, 3, c, file_, number);
            mesh_.normals.emplace_back(c[0], c[1], c[2]);
        } else if (keyword == "vt") {
            const int count = ReadNumbers(rest, keyword, 1, 3, c, file_, number);
            mesh_.texcoords.emplace_back(c[0], count > 1 ? c[1] : 0.0f);
        } else if (keyword == "o" || keyword == "g") {
            mesh_.groups.emplace_back(Trim(rest));
            group_ = int32_t(mesh_.groups.size() - 1);
        } else if (keyword == "usemtl") {
            UseMaterial(Trim(rest), number);
        } else if (keyword == "mtllib") {
            MaterialLibraries(rest, number);
        }
        // Anything else (s, l, p, vp, curves, ...) does not describe triangles: ignored.
    }

    // Resolves one OBJ index (1-based, or negative relative to the end) against `count`.
    int32_t Index(std::string_view text, const char* what, const char* whatPlural, size_t count,
                  std::string_view corner, int line) const {
        long long value = 0;
        const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
        if (end != text.data() + text.size() || text.empty()) {
            Fail(file_, line, "malformed face vertex " + Quoted(corner) + " in 'f' statement");
        }
        if (error == std::errc() && value == 0) Fail(file_, line, "index 0 is not allowed");
        const long long n = static_cast<long long>(count);
        const long long resolved = value > 0 ? value - 1 : n + value;
        if (error != std::errc() || resolved < 0 || resolved >= n) {
            Fail(file_, line,
                 std::string(what) + " index " + std::string(text) + " out of range (" +
                     std::to_string(count) + " " + (count == 1 ? what : whatPlural) + " defined)");
        }
        return int32_t(resolved);
    }

    Corner ParseCorner(std::string_view token, int line) const {
        const size_t slash1 = token.find('/');
        const size_t slash2 =
            slash1 == std::string_view::npos ? slash1 : token.find('/', slash1 + 1);
        const bool malformed = (slash2 != std::string_view::npos &&
                                (token.find('/', slash2 + 1) != std::string_view::npos ||
                                 slash2 + 1 == token.size())) ||
                               (slash1 != std::string_view::npos &&
                                slash2 == std::string_view::npos && slash1 + 1 == token.size());
        if (malformed) {
            Fail(file_, line, "malformed face vertex " + Quoted(token) + " in 'f' statement");
        }
        Corner c{0, kObjNone, kObjNone};
        c.position = uint32_t(Index(token.substr(0, slash1), "vertex", "vertices",
                                    mesh_.positions.size(), token, line));
        if (slash1 == std::string_view::npos) return c;
        const std::string_view texcoord = token.substr(slash1 + 1, slash2 - slash1 - 1);
        if (!texcoord.empty()) {
            c.texcoord =
                Index(texcoord, "texcoord", "texcoords", mesh_.texcoords.size(), token, line);
        }
        if (slash2 != std::string_view::npos) {
            c.normal = Index(token.substr(slash2 + 1), "normal", "normals", mesh_.normals.size(),
                             token, line);
        }
        return c;
    }

    void Face(std::string_view rest, int line) {
        corners_.clear();
        for (std::string_view token = NextToken(rest); !token.empty(); token = NextToken(rest)) {
            corners_.push_back(ParseCorner(token, line));
        }
        if (corners_.size() < 3) Fail(file_, line, "face with fewer than 3 vertices");
        for (size_t i = 1; i + 1 < corners_.size(); ++i) {
            ObjTriangle t;
            const Corner* fan[3] = {&corners_[0], &corners_[i], &corners_[i + 1]};
            for (int k = 0; k < 3; ++k) {
                t.position[k] = fan[k]->position;
                t.normal[k] = fan[k]->normal;
                t.texcoord[k] = fan[k]->texcoord;
            }
            t.material = material_;
            t.group = group_;
            mesh_.triangles.push_back(t);
        }
    }

    // Names are resolved after the whole file is read, so a usemtl may precede its mtllib.
    void UseMaterial(std::string_view name, int line) {
        if (name.empty()) Fail(file_, line, "'usemtl' needs a material name");
        const auto [it, added] = usedIndex_.try_emplace(std::string(name), int32_t(used_.size()));
        if (added) used_.push_back({std::string(name), line});
        material_ = it->second;
    }

    void MaterialLibraries(std::string_view rest, int line) {
        int count = 0;
        for (std::string_view name = NextToken(rest); !name.empty(); name = NextToken(rest)) {
            ++count;
            const fs::path path = file_.parent_path() / fs::path(name);
            if (!loaded_.insert(path.string()).second) continue;
            const FileText mtl = ReadFile(path);
            if (!mtl.problem.empty()) {
                Fail(file_, line, "material library " + Quoted(path.string()) + ": " + mtl.problem);
            }
            for (Material& m : ParseMtl(mtl.text, path)) mesh_.materials.push_back(std::move(m));
        }
        if (count == 0) Fail(file_, line, "'mtllib' needs a file name");
    }

    void ResolveMaterials() {
        // A later definition of a name replaces an earlier one, as in most OBJ readers.
        std::unordered_map<std::string_view, int32_t> byName;
        for (size_t i = 0; i < mesh_.materials.size(); ++i) {
            byName[mesh_.materials[i].name] = int32_t(i);
        }
        std::vector<int32_t> resolved(used_.size());
        for (size_t i = 0; i < used_.size(); ++i) {
            const auto it = byName.find(used_[i].name);
            if (it == byName.end()) {
                Fail(file_, used_[i].line, "unknown material " + Quoted(used_[i].name));
            }
            resolved[i] = it->second;
        }
        for (ObjTriangle& t : mesh_.triangles) {
            if (t.material != kObjNone) t.material = resolved[size_t(t.material)];
        }
    }

    const fs::path& file_;
    ObjMesh mesh_;
    std::vector<Corner> corners_;  // of the current face, reused
    int32_t material_ = kObjNone;  // index into used_ until ResolveMaterials
    int32_t group_ = kObjNone;
    std::vector<UsedMaterial> used_;
    std::unordered_map<std::string, int32_t> usedIndex_;
    std::unordered_set<std::string> loaded_;
};

}  // namespace

std::vector<Material> ParseMtl(std::string_view text, const fs::path& file) {
    std::vector<Material> materials;
    MtlEntry entry;
    bool open = false;
    const auto finish = [&]() {
        if (open) materials.push_back(ToWhitted(entry));
    };
    LineReader lines(text);
    std::string_view line;
    int number = 0;
    while (lines.Next(line, number)) {
        std::string_view rest = line;
        const std::string_view keyword = NextToken(rest);
        if (keyword == "newmtl") {
            const std::string_view name = Trim(rest);
            if (name.empty()) Fail(file, number, "'newmtl' needs a material name");
            finish();
            entry = MtlEntry{};
            entry.material.name = std::string(name);
            open = true;
            continue;
        }
        const bool known = keyword == "Kd" || keyword == "Ks" || keyword == "Ke" ||
                           keyword == "Ns" || keyword == "Ni" || keyword == "d" ||
                           keyword == "Tr" || keyword == "illum";
        if (!known) continue;  // Ka, map_*, Tf, Pr, ...: nothing the Whitted model uses
        if (!open) Fail(file, number, Quoted(keyword) + " statement before 'newmtl'");
        Material& m = entry.material;
        if (keyword == "Kd") {
            m.kd = ReadColor(rest, keyword, file, number);
        } else if (keyword == "Ks") {
            m.ks = ReadColor(rest, keyword, file, number);
        } else if (keyword == "Ke") {
            m.emission = ReadColor(rest, keyword, file, number);
        } else if (keyword == "Ns") {
            m.shininess = ReadScalar(rest, keyword, file, number);
            if (m.shininess < 0.0f) FailRange(keyword, rest, file, number);
        } else if (keyword == "Ni") {
            m.ior = ReadScalar(rest, keyword, file, number);
            if (m.ior <= 0.0f) FailRange(keyword, rest, file, number);
        } else if (keyword == "d" || keyword == "Tr") {
            const float value = ReadScalar(rest, keyword, file, number);
            if (value < 0.0f || value > 1.0f) FailRange(keyword, rest, file, number);
            entry.dissolve = keyword == "d" ? value : 1.0f - value;
        } else {
            const std::string_view token = Trim(rest);
            int illum = 0;
            const auto [end, error] =
                std::from_chars(token.data(), token.data() + token.size(), illum);
            if (token.empty() || end != token.data() + token.size() || error != std::errc()) {
                Fail(file, number, "malformed number " + Quoted(token) + " in 'illum' statement");
            }
            if (illum < 0 || illum > 10) FailRange(keyword, rest, file, number);
            entry.illum = illum;
        }
    }
    finish();
    return materials;
}

int StatementLine(std::string_view text, std::string_view keyword, size_t index) {
    LineReader lines(text);
    std::string_view line;
    int number = 0;
    while (lines.Next(line, number)) {
        if (NextToken(line) == keyword && index-- == 0) return number;
    }
    return 0;
}

ObjMesh ParseObj(std::string_view text, const fs::path& file) {
    return ObjParser(file).Parse(text);
}

ObjMesh LoadObj(const fs::path& file) {
    const FileText obj = ReadFile(file);
    if (!obj.problem.empty()) Fail(file, 0, obj.problem);
    return ParseObj(obj.text, file);
}

}  // namespace rayclass::scene
