#include "rayclass/scene/obj.h"

#include <algorithm>
#include <charconv>
#include <exception>
#include <iterator>
#include <latch>
#include <optional>
#include <string>
#include <thread>
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

// What the text before a piece of it leaves for the piece: the physical lines, the numbered
// statements (indices count from the file's start), and the current material.
struct PieceStart {
    int lines = 0;
    uint32_t positions = 0, normals = 0, texcoords = 0, groups = 0;
    bool hasMaterial = false;
    std::string material;  // the last usemtl's name
};

// What a piece adds to the PieceStart of the next one, read as the parser reads lines (malformed
// statements count too: an error before the next piece is reported first anyway).
PieceStart Count(std::string_view piece) {
    PieceStart s;
    LineReader lines(piece);
    std::string_view line;
    int number = 0;
    while (lines.Next(line, number)) {
        std::string_view rest = line;
        const std::string_view keyword = NextToken(rest);
        if (keyword == "v") {
            ++s.positions;
        } else if (keyword == "vn") {
            ++s.normals;
        } else if (keyword == "vt") {
            ++s.texcoords;
        } else if (keyword == "o" || keyword == "g") {
            ++s.groups;
        } else if (keyword == "usemtl") {
            s.hasMaterial = true;
            s.material = std::string(Trim(rest));
        }
    }
    s.lines = lines.PhysicalLines();
    return s;
}

// `to` followed by a piece that adds `piece` (Count's).
void Add(PieceStart& to, const PieceStart& piece) {
    if (piece.hasMaterial) {
        to.hasMaterial = true;
        to.material = piece.material;
    }
    to.lines += piece.lines;
    to.positions += piece.positions;
    to.normals += piece.normals;
    to.texcoords += piece.texcoords;
    to.groups += piece.groups;
}

struct UsedMaterial {
    std::string name;
    int line;  // first usemtl naming it
};

// The statements of one piece of an OBJ file (or of all of it) into a mesh of the piece's own:
// its vertices, groups and triangles, with indices into the whole file's arrays; its triangles'
// materials index its `used` names until the pieces are joined.
class ObjParser {
  public:
    ObjParser(const fs::path& file, const PieceStart& start) : file_(file), start_(start) {
        if (start.groups > 0) group_ = int32_t(start.groups - 1);
        // The line is never reported: the piece with the usemtl lists the name first.
        if (start.hasMaterial) UseMaterial(start.material, 0);
    }

    void Parse(std::string_view piece) {
        LineReader lines(piece, start_.lines);
        std::string_view line;
        int number = 0;
        while (lines.Next(line, number)) Statement(line, number);
    }

    ObjMesh mesh_;
    std::vector<UsedMaterial> used_;
    // The libraries the piece loaded, in order: each one's path and its materials' end in
    // mesh_.materials.
    std::vector<std::pair<std::string, size_t>> libraries_;

  private:
    struct Corner {
        uint32_t position;
        int32_t texcoord;
        int32_t normal;
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
            group_ = int32_t(start_.groups + mesh_.groups.size() - 1);
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
                                    start_.positions + mesh_.positions.size(), token, line));
        if (slash1 == std::string_view::npos) return c;
        const std::string_view texcoord = token.substr(slash1 + 1, slash2 - slash1 - 1);
        if (!texcoord.empty()) {
            c.texcoord = Index(texcoord, "texcoord", "texcoords",
                               start_.texcoords + mesh_.texcoords.size(), token, line);
        }
        if (slash2 != std::string_view::npos) {
            c.normal = Index(token.substr(slash2 + 1), "normal", "normals",
                             start_.normals + mesh_.normals.size(), token, line);
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
            libraries_.emplace_back(path.string(), mesh_.materials.size());
        }
        if (count == 0) Fail(file_, line, "'mtllib' needs a file name");
    }

    const fs::path& file_;
    const PieceStart start_;
    std::vector<Corner> corners_;  // of the current face, reused
    int32_t material_ = kObjNone;  // index into used_ until the pieces are joined
    int32_t group_ = kObjNone;
    std::unordered_map<std::string, int32_t> usedIndex_;
    std::unordered_set<std::string> loaded_;
};

// Text is cut into pieces of at least this size, one a core. Smaller files gained nothing in a
// render on 2 cores, whose other core starts OpenCL meanwhile (a split Sibenik loaded no faster).
constexpr size_t kPieceBytesMin = size_t(4) << 20;
// Count's time over a parse's, per byte, as measured on Conference's text in one piece.
constexpr double kCountShare = 0.1;

// `pieces` pieces of the text, each starting at a logical line. Piece 0 is larger by the share
// of their time the other threads spend counting the piece before theirs first.
std::vector<std::string_view> Pieces(std::string_view text, size_t pieces) {
    const double first = 1.0 / (1.0 + double(pieces - 1) * (1.0 - kCountShare));
    std::vector<std::string_view> out;
    size_t at = 0;
    for (size_t k = 1; k < pieces && at < text.size(); ++k) {
        const double share = first + double(k - 1) * first * (1.0 - kCountShare);
        size_t end = std::max(at, size_t(share * double(text.size())));
        for (;;) {
            const size_t newline = text.find('\n', end);
            if (newline == std::string_view::npos) {
                end = text.size();
                break;
            }
            end = newline + 1;
            if (!ContinuesBefore(text, newline)) break;
        }
        out.push_back(text.substr(at, end - at));
        at = end;
    }
    if (at < text.size() || out.empty()) out.push_back(text.substr(at));
    return out;
}

// Joins the pieces' meshes in file order. A library an earlier piece loaded is skipped; the used
// names, taken in order of first use, are resolved against all materials (a later definition
// of a name replaces an earlier one, as in most OBJ readers), so an unknown one fails at its
// first usemtl, as it would in one piece.
ObjMesh Join(std::vector<std::optional<ObjParser>>& parts, const fs::path& file) {
    ObjMesh mesh;
    std::unordered_set<std::string> loaded;
    for (auto& part : parts) {
        size_t begin = 0;
        for (const auto& [path, end] : part->libraries_) {
            if (loaded.insert(path).second) {
                std::move(part->mesh_.materials.begin() + ptrdiff_t(begin),
                          part->mesh_.materials.begin() + ptrdiff_t(end),
                          std::back_inserter(mesh.materials));
            }
            begin = end;
        }
    }
    std::unordered_map<std::string_view, int32_t> byName;
    for (size_t i = 0; i < mesh.materials.size(); ++i) byName[mesh.materials[i].name] = int32_t(i);
    std::unordered_map<std::string_view, int32_t> material;
    std::vector<std::vector<int32_t>> local(parts.size());
    for (size_t p = 0; p < parts.size(); ++p) {
        for (const UsedMaterial& used : parts[p]->used_) {
            const auto [it, added] = material.try_emplace(used.name, 0);
            if (added) {
                const auto found = byName.find(used.name);
                if (found == byName.end()) {
                    Fail(file, used.line, "unknown material " + Quoted(used.name));
                }
                it->second = found->second;
            }
            local[p].push_back(it->second);
        }
    }
    size_t triangles = 0;
    for (const auto& part : parts) triangles += part->mesh_.triangles.size();
    mesh.triangles.reserve(triangles);
    const auto append = [](auto& to, auto& from) {
        if (to.empty()) {
            to = std::move(from);
        } else {
            to.insert(to.end(), std::make_move_iterator(from.begin()),
                      std::make_move_iterator(from.end()));
        }
    };
    for (size_t p = 0; p < parts.size(); ++p) {
        ObjMesh& m = parts[p]->mesh_;
        for (ObjTriangle t : m.triangles) {
            if (t.material != kObjNone) t.material = local[p][size_t(t.material)];
            mesh.triangles.push_back(t);
        }
        append(mesh.positions, m.positions);
        append(mesh.normals, m.normals);
        append(mesh.texcoords, m.texcoords);
        append(mesh.groups, m.groups);
    }
    return mesh;
}

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

ObjMesh ParseObj(std::string_view text, const fs::path& file, size_t pieces) {
    if (pieces == 0) {
        pieces = std::clamp<size_t>(std::thread::hardware_concurrency(), 1,
                                    std::max<size_t>(1, text.size() / kPieceBytesMin));
    }
    const std::vector<std::string_view> piece = Pieces(text, pieces);
    const size_t n = piece.size();
    // Piece 0 is parsed at once. Thread k > 0 counts piece k - 1, then, once every count is
    // in, parses piece k from the sum of the counts before it. A piece's first error is the
    // file's once no earlier piece has one.
    std::vector<PieceStart> added(n);
    std::vector<std::optional<ObjParser>> parts(n);
    std::vector<std::exception_ptr> failed(n);
    std::latch counted(std::ptrdiff_t(n - 1));
    auto run = [&](size_t k) {
        PieceStart start;
        if (k > 0) {
            // Counted down whatever happens: the other threads wait for every count.
            try {
                added[k - 1] = Count(piece[k - 1]);
            } catch (...) {
                failed[k] = std::current_exception();
            }
            counted.count_down();
            counted.wait();
            if (failed[k]) return;
            for (size_t j = 0; j < k; ++j) Add(start, added[j]);
        }
        try {
            parts[k].emplace(file, start);
            parts[k]->Parse(piece[k]);
        } catch (...) {
            failed[k] = std::current_exception();
        }
    };
    std::exception_ptr noThread;
    {
        std::vector<std::jthread> threads;
        for (size_t k = 1; k < n && !noThread; ++k) {
            try {
                threads.emplace_back(run, k);
            } catch (...) {
                noThread = std::current_exception();
                counted.count_down(std::ptrdiff_t(n - k));  // for the threads that never ran
            }
        }
        if (!noThread) run(0);
    }
    if (noThread) std::rethrow_exception(noThread);
    for (const std::exception_ptr& e : failed) {
        if (e) std::rethrow_exception(e);
    }
    return Join(parts, file);
}

ObjMesh LoadObj(const fs::path& file) {
    const FileText obj = ReadFile(file);
    if (!obj.problem.empty()) Fail(file, 0, obj.problem);
    return ParseObj(obj.text, file);
}

}  // namespace rayclass::scene
