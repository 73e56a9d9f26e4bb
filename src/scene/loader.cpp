#include "rayclass/scene/loader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <glm/gtc/matrix_transform.hpp>
#include <iterator>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "rayclass/core/error.h"
#include "rayclass/scene/obj.h"
#include "rayclass/scene/patch.h"
#include "text_input.h"

namespace rayclass::scene {

namespace {

namespace fs = std::filesystem;
// Ordered, so a pre-order walk of the tree meets values in the order the parser produced them.
using Json = nlohmann::ordered_json;

constexpr int kMaxDepth = 64;
constexpr uint64_t kMaxImageSide = 16384;

std::string Quoted(std::string_view s) {
    std::string quoted(1, '\'');
    quoted.append(s).push_back('\'');
    return quoted;
}

// Counts lines while nlohmann's lexer pulls characters, so that each SAX event knows the line of
// the token it reports: the line of the last non-blank character read (a number's one character
// of lookahead is a delimiter, blank or on the same line).
struct LineCounter {
    int line = 1;
    int tokenLine = 1;
};

class CountingIterator {
  public:
    using iterator_category = std::forward_iterator_tag;
    using value_type = char;
    using difference_type = std::ptrdiff_t;
    using pointer = const char*;
    using reference = const char&;

    CountingIterator(const char* p, LineCounter* counter) : p_(p), counter_(counter) {}
    reference operator*() const { return *p_; }
    CountingIterator& operator++() {
        if (*p_ == '\n') {
            ++counter_->line;
        } else if (*p_ != ' ' && *p_ != '\t' && *p_ != '\r') {
            counter_->tokenLine = counter_->line;
        }
        ++p_;
        return *this;
    }
    CountingIterator operator++(int) {
        CountingIterator old = *this;
        ++*this;
        return old;
    }
    bool operator==(const CountingIterator& other) const { return p_ == other.p_; }

  private:
    const char* p_;
    LineCounter* counter_;
};

// Builds the tree from SAX events, records each value's line in pre-order, rejects duplicate keys
// and bounds the nesting depth (deep nesting would otherwise only cost memory, but no scene needs
// it and the tree's users recurse).
class TreeBuilder : public nlohmann::json_sax<Json> {
  public:
    TreeBuilder(const fs::path& file, std::string_view text, const LineCounter& counter)
        : file_(file), text_(text), counter_(counter) {}

    Json& root() { return root_; }
    const std::vector<int>& lines() const { return lines_; }

    bool null() override { return Value(nullptr); }
    bool boolean(bool v) override { return Value(v); }
    bool number_integer(number_integer_t v) override { return Value(v); }
    bool number_unsigned(number_unsigned_t v) override { return Value(v); }
    bool number_float(number_float_t v, const string_t&) override { return Value(v); }
    bool string(string_t& v) override { return Value(std::move(v)); }
    bool binary(binary_t& v) override { return Value(Json::binary(std::move(v))); }
    bool start_object(std::size_t) override { return Open(Json::object()); }
    bool start_array(std::size_t) override { return Open(Json::array()); }
    bool end_object() override { return Close(); }
    bool end_array() override { return Close(); }

    bool key(string_t& k) override {
        Json& object = *open_.back();
        if (object.contains(k)) Fail(counter_.tokenLine, "duplicate key " + Quoted(k));
        slot_ = &object[k];
        return true;
    }

    bool parse_error(std::size_t position, const std::string&, const Json::exception& e) override {
        // e.what() reads "[json.exception.KIND.ID] parse error at line L, column C: DETAIL";
        // keep DETAIL, the line comes from the byte position.
        std::string_view detail = e.what();
        detail.remove_prefix(std::min(detail.find("] ") + 2, detail.size()));
        if (const size_t column = detail.find(", column "); column != std::string_view::npos) {
            detail.remove_prefix(std::min(detail.find(": ", column) + 2, detail.size()));
        }
        std::string problem(detail);
        // "last read" quotes everything since the previous token, newlines included: noise.
        if (const size_t read = problem.find("; last read: "); read != std::string::npos) {
            problem.erase(read, problem.find("; expected", read) - read);
        }
        const size_t end = std::min(position > 0 ? position - 1 : 0, text_.size());
        Fail(1 + int(std::count(text_.begin(), text_.begin() + std::ptrdiff_t(end), '\n')),
             problem);
    }

  private:
    [[noreturn]] void Fail(int line, std::string problem) const {
        throw SceneError(file_.string(), line, std::move(problem));
    }

    Json* Place(Json&& value) {
        lines_.push_back(counter_.tokenLine);
        if (open_.empty()) {
            root_ = std::move(value);
            return &root_;
        }
        Json& parent = *open_.back();
        if (parent.is_array()) {
            parent.push_back(std::move(value));
            return &parent.back();
        }
        *slot_ = std::move(value);
        return slot_;
    }

    template <typename T>
    bool Value(T&& v) {
        Place(Json(std::forward<T>(v)));
        return true;
    }

    bool Open(Json&& container) {
        if (int(open_.size()) >= kMaxDepth) {
            Fail(counter_.tokenLine,
                 "nesting deeper than " + std::to_string(kMaxDepth) + " levels");
        }
        open_.push_back(Place(std::move(container)));
        return true;
    }

    bool Close() {
        open_.pop_back();
        return true;
    }

    const fs::path& file_;
    std::string_view text_;
    const LineCounter& counter_;
    Json root_;
    std::vector<Json*> open_;  // containers being filled, innermost last
    Json* slot_ = nullptr;     // value of the key just read
    std::vector<int> lines_;   // line of every value, in pre-order
};

// Scene index of the material named like `m`, appending `m` when the scene has none of that name
// (so materials the scene file defines win over a mesh's MTL definitions).
uint32_t SceneMaterial(Scene& scene, const Material& m) {
    for (size_t i = 0; i < scene.materials.size(); ++i) {
        if (scene.materials[i].name == m.name) return uint32_t(i);
    }
    scene.materials.push_back(m);
    return uint32_t(scene.materials.size() - 1);
}

bool InRange(float x) { return std::fabs(x) <= kMaxCoordinate; }  // false for NaN
bool InRange(const glm::vec3& p) { return InRange(p.x) && InRange(p.y) && InRange(p.z); }

std::string MaxCoordinateText() {
    char text[32];
    std::snprintf(text, sizeof text, "%g", double(kMaxCoordinate));
    return text;
}

// Primitive ids are uint32_t and RC_NO_HIT (~0u) marks a miss.
constexpr uint64_t kMaxPrimitives = 0xfffffffeull;

// Appends the mesh's triangles in world space as scene object `object`; every triangle takes
// `materialOverride` when set, else its MTL material (the default material without usemtl).
// Returns the index (into mesh.positions) of a used vertex whose world position is beyond
// kMaxCoordinate (or not finite), after appending nothing; nullopt on success. Throws
// `tooMany` when the scene would have more primitives than ids.
std::optional<uint32_t> AppendMesh(Scene& scene, const ObjMesh& mesh, const glm::mat4& toWorld,
                                   std::optional<uint32_t> materialOverride, uint32_t object) {
    std::vector<bool> checked(mesh.positions.size(), false);
    for (const ObjTriangle& t : mesh.triangles) {
        for (const uint32_t i : t.position) {
            if (checked[i]) continue;
            checked[i] = true;
            if (!InRange(glm::vec3(toWorld * glm::vec4(mesh.positions[i], 1.0f)))) return i;
        }
    }
    if (uint64_t(scene.PrimitiveCount()) + mesh.triangles.size() > kMaxPrimitives) {
        throw std::length_error("more than " + std::to_string(kMaxPrimitives) + " primitives");
    }
    std::vector<uint32_t> materials(mesh.materials.size());
    if (!materialOverride) {
        for (size_t i = 0; i < materials.size(); ++i) {
            materials[i] = SceneMaterial(scene, mesh.materials[i]);
        }
    }
    const glm::mat3 normalToWorld = glm::transpose(glm::inverse(glm::mat3(toWorld)));
    scene.triangles.reserve(scene.triangles.size() + mesh.triangles.size());
    for (const ObjTriangle& t : mesh.triangles) {
        Triangle& out = scene.triangles.emplace_back();
        out.hasNormals = true;
        for (int k = 0; k < 3; ++k) {
            out.p[k] = glm::vec3(toWorld * glm::vec4(mesh.positions[t.position[k]], 1.0f));
            out.n[k] = glm::vec3(0.0f);
            if (t.normal[k] == kObjNone) {
                out.hasNormals = false;
                continue;
            }
            const glm::vec3 n = normalToWorld * mesh.normals[size_t(t.normal[k])];
            const float length = glm::length(n);
            // A zero normal cannot shade; the triangle falls back to its geometric normal.
            if (!(length > 0.0f) || !std::isfinite(length)) out.hasNormals = false;
            out.n[k] = length > 0.0f ? n / length : n;
        }
        if (!out.hasNormals) out.n.fill(glm::vec3(0.0f));
        // A triangle of zero area in float (collinear or coincident corners) has no normal to
        // shade with, yet rounding in either triangle test still reports hits on it when its
        // edges are exact multiples of each other (tests/geometry/stability_test.cpp measured
        // 2% of rays through one with Moeller-Trumbore, 34% watertight). Collapsed onto its
        // first corner, both tests see e1 = e2 = 0 and never hit it; it keeps its id.
        const glm::vec3 area = glm::cross(out.p[1] - out.p[0], out.p[2] - out.p[0]);
        if (area == glm::vec3(0.0f)) out.p[1] = out.p[2] = out.p[0];
        out.material = materialOverride         ? *materialOverride
                       : t.material == kObjNone ? 0u
                                                : materials[size_t(t.material)];
        out.object = object;
    }
    return std::nullopt;
}

std::string Lowercase(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

class SceneFileReader {
  public:
    SceneFileReader(const fs::path& file, std::string_view text) : file_(file), text_(text) {}

    Scene Read() {
        LineCounter counter;
        TreeBuilder builder(file_, text_, counter);
        Json::sax_parse(CountingIterator(text_.data(), &counter),
                        CountingIterator(text_.data() + text_.size(), &counter), &builder);
        const Json& root = builder.root();
        size_t next = 0;
        IndexLines(root, builder.lines(), next);

        if (!root.is_object()) Fail(root, "scene: the top level must be a JSON object");
        CheckKeys(root,
                  {"camera", "ambient", "background", "materials", "lights", "objects",
                   "patch_flatness"},
                  "scene");
        if (const Json* v = Find(root, "patch_flatness")) {
            scene_.patchFlatness = Positive(*v, "patch_flatness", "scene");
        }
        if (const Json* v = Find(root, "ambient")) scene_.ambient = Color(*v, "ambient", "scene");
        if (const Json* v = Find(root, "background")) {
            scene_.background = Color(*v, "background", "scene");
        }
        if (const Json* v = Find(root, "materials")) Materials(*v);
        if (const Json* v = Find(root, "lights")) Lights(*v);
        if (const Json* v = Find(root, "objects")) Objects(*v);
        SplitPatches(scene_, PatchSplit{scene_.patchFlatness, 0});
        if (const Json* v = Find(root, "camera")) {
            scene_.camera = ReadCamera(*v);
            if (const Json* path = Find(*v, "path")) scene_.cameraPath = ReadCameraPath(*path);
        } else {
            const Bounds3f bounds = scene_.Bounds();
            if (bounds.Empty()) Fail(root, "scene: no 'camera' and nothing to frame");
            scene_.camera = FramingCamera(bounds, 800, 600);
        }
        return std::move(scene_);
    }

  private:
    void IndexLines(const Json& v, const std::vector<int>& lines, size_t& next) {
        line_[&v] = next < lines.size() ? lines[next] : 0;
        ++next;
        if (v.is_structured()) {
            for (const Json& child : v) IndexLines(child, lines, next);
        }
    }

    [[noreturn]] void Fail(const Json& where, std::string problem) const {
        const auto it = line_.find(&where);
        throw SceneError(file_.string(), it == line_.end() ? 0 : it->second, std::move(problem));
    }

    static const Json* Find(const Json& object, const char* key) {
        const auto it = object.find(key);
        return it == object.end() ? nullptr : &*it;
    }

    const Json& Require(const Json& object, const char* key, const std::string& context) const {
        const Json* v = Find(object, key);
        if (!v) Fail(object, context + ": missing " + Quoted(key));
        return *v;
    }

    void CheckKeys(const Json& object, std::initializer_list<std::string_view> allowed,
                   const std::string& context, std::string_view in = {}) const {
        for (const auto& item : object.items()) {
            if (std::find(allowed.begin(), allowed.end(), item.key()) == allowed.end()) {
                Fail(item.value(), context + ": unknown key " + Quoted(item.key()) +
                                       (in.empty() ? "" : " in " + Quoted(in)));
            }
        }
    }

    const Json& RequireObject(const Json& v, const std::string& what) const {
        if (!v.is_object()) Fail(v, what + " must be a JSON object");
        return v;
    }

    static std::optional<float> Finite(const Json& v) {
        if (!v.is_number()) return std::nullopt;
        const float f = v.get<float>();
        if (!std::isfinite(f)) return std::nullopt;
        return f;
    }

    // An array of `n` finite numbers, else nullopt.
    static std::optional<std::vector<float>> Numbers(const Json& v, size_t n) {
        if (!v.is_array() || v.size() != n) return std::nullopt;
        std::vector<float> out;
        for (const Json& e : v) {
            const auto f = Finite(e);
            if (!f) return std::nullopt;
            out.push_back(*f);
        }
        return out;
    }

    glm::vec3 Vec3(const Json& v, const char* key, const std::string& context) const {
        const auto n = Numbers(v, 3);
        if (!n) Fail(v, context + ": " + Quoted(key) + " must be an array of 3 finite numbers");
        return {(*n)[0], (*n)[1], (*n)[2]};
    }

    // A point or a length of the scene: finite and at most kMaxCoordinate in magnitude.
    glm::vec3 Position(const Json& v, const char* key, const std::string& context) const {
        const glm::vec3 p = Vec3(v, key, context);
        if (!InRange(p)) {
            Fail(v, context + ": " + Quoted(key) + " is out of range (magnitude above " +
                        MaxCoordinateText() + ")");
        }
        return p;
    }

    glm::vec3 Color(const Json& v, const char* key, const std::string& context) const {
        const auto n = Numbers(v, 3);
        if (!n || *std::min_element(n->begin(), n->end()) < 0.0f) {
            Fail(v, context + ": " + Quoted(key) +
                        " must be an array of 3 non-negative finite numbers");
        }
        return {(*n)[0], (*n)[1], (*n)[2]};
    }

    // A colour or one number for all three channels (kr, kt, light intensity).
    glm::vec3 ColorOrNumber(const Json& v, const char* key, const std::string& context) const {
        if (const auto f = Finite(v); f && *f >= 0.0f) return glm::vec3(*f);
        const auto n = Numbers(v, 3);
        if (!n || *std::min_element(n->begin(), n->end()) < 0.0f) {
            Fail(v, context + ": " + Quoted(key) +
                        " must be a non-negative finite number or an array of 3");
        }
        return {(*n)[0], (*n)[1], (*n)[2]};
    }

    float Positive(const Json& v, const char* key, const std::string& context) const {
        const auto f = Finite(v);
        if (!f || *f <= 0.0f) Fail(v, context + ": " + Quoted(key) + " must be a positive number");
        return *f;
    }

    float NonNegative(const Json& v, const char* key, const std::string& context) const {
        const auto f = Finite(v);
        if (!f || *f < 0.0f) {
            Fail(v, context + ": " + Quoted(key) + " must be a non-negative number");
        }
        return *f;
    }

    const std::string& String(const Json& v, const char* key, const std::string& context) const {
        if (!v.is_string()) Fail(v, context + ": " + Quoted(key) + " must be a string");
        return v.get_ref<const std::string&>();
    }

    uint32_t MaterialNamed(const Json& v, const std::string& context) const {
        const std::string& name = String(v, "material", context);
        for (size_t i = 0; i < scene_.materials.size(); ++i) {
            if (scene_.materials[i].name == name) return uint32_t(i);
        }
        Fail(v, context + ": unknown material " + Quoted(name));
    }

    void Materials(const Json& all) {
        RequireObject(all, "scene: 'materials'");
        for (const auto& item : all.items()) {
            const std::string context = "material " + Quoted(item.key());
            const Json& v = RequireObject(item.value(), context + ":");
            CheckKeys(v, {"kd", "ks", "shininess", "kr", "kt", "ior", "fresnel", "emission"},
                      context);
            Material m;
            m.name = item.key();
            if (const Json* e = Find(v, "kd")) m.kd = Color(*e, "kd", context);
            if (const Json* e = Find(v, "ks")) m.ks = Color(*e, "ks", context);
            if (const Json* e = Find(v, "shininess"))
                m.shininess = NonNegative(*e, "shininess", context);
            if (const Json* e = Find(v, "kr")) m.kr = ColorOrNumber(*e, "kr", context);
            if (const Json* e = Find(v, "kt")) m.kt = ColorOrNumber(*e, "kt", context);
            if (const Json* e = Find(v, "ior")) m.ior = Positive(*e, "ior", context);
            if (const Json* e = Find(v, "emission")) m.emission = Color(*e, "emission", context);
            if (const Json* e = Find(v, "fresnel")) {
                if (!e->is_boolean()) Fail(*e, context + ": 'fresnel' must be true or false");
                m.fresnel = e->get<bool>();
            }
            // "default" replaces the built-in default material (index 0).
            if (m.name == scene_.materials[0].name) {
                scene_.materials[0] = m;
            } else {
                scene_.materials.push_back(m);
            }
        }
    }

    void Lights(const Json& all) {
        if (!all.is_array()) Fail(all, "scene: 'lights' must be an array");
        for (size_t i = 0; i < all.size(); ++i) {
            const std::string context = "light " + std::to_string(i + 1);
            const Json& v = RequireObject(all[i], context + ":");
            CheckKeys(v, {"position", "intensity"}, context);
            PointLight light;
            light.position = Position(Require(v, "position", context), "position", context);
            if (const Json* e = Find(v, "intensity")) {
                light.intensity = ColorOrNumber(*e, "intensity", context);
            }
            scene_.lights.push_back(light);
        }
    }

    void Objects(const Json& all) {
        if (!all.is_array()) Fail(all, "scene: 'objects' must be an array");
        for (size_t i = 0; i < all.size(); ++i) {
            const std::string context = "object " + std::to_string(i + 1);
            const Json& v = RequireObject(all[i], context + ":");
            const std::string& type = String(Require(v, "type", context), "type", context);
            const uint32_t index = uint32_t(scene_.objects.size());
            std::string defaultName = type + " " + std::to_string(i + 1);
            if (type == "mesh") {
                CheckKeys(v, {"type", "file", "transform", "material", "name"}, context);
                defaultName = Mesh(v, context, index);
            } else if (type == "sphere") {
                CheckKeys(v, {"type", "center", "radius", "material", "name"}, context);
                Sphere s;
                s.center = Position(Require(v, "center", context), "center", context);
                const Json& radius = Require(v, "radius", context);
                s.radius = Positive(radius, "radius", context);
                if (!InRange(s.radius)) {
                    Fail(radius, context + ": 'radius' is out of range (magnitude above " +
                                     MaxCoordinateText() + ")");
                }
                if (const Json* e = Find(v, "material")) s.material = MaterialNamed(*e, context);
                s.object = index;
                scene_.spheres.push_back(s);
            } else if (type == "quadric") {
                CheckKeys(v, {"type", "coefficients", "box_min", "box_max", "material", "name"},
                          context);
                Quadric q;
                const Json& c = Require(v, "coefficients", context);
                const auto n = Numbers(c, 10);
                if (!n) Fail(c, context + ": 'coefficients' must be an array of 10 finite numbers");
                std::copy(n->begin(), n->end(), q.c.begin());
                q.boxMin = Position(Require(v, "box_min", context), "box_min", context);
                const Json& boxMax = Require(v, "box_max", context);
                q.boxMax = Position(boxMax, "box_max", context);
                if (glm::any(glm::greaterThan(q.boxMin, q.boxMax))) {
                    Fail(boxMax, context + ": 'box_min' must not exceed 'box_max'");
                }
                if (const Json* e = Find(v, "material")) q.material = MaterialNamed(*e, context);
                q.object = index;
                scene_.quadrics.push_back(q);
            } else if (type == "bezier") {
                CheckKeys(v, {"type", "file", "patches", "degree", "transform", "material", "name"},
                          context);
                if (const std::string file = Bezier(v, context, index); !file.empty()) {
                    defaultName = file;
                }
            } else if (type == "nurbs") {
                CheckKeys(v, {"type", "degree", "knots", "points", "transform", "material", "name"},
                          context);
                Nurbs(v, context, index);
            } else {
                Fail(*Find(v, "type"), context + ": unknown type " + Quoted(type) +
                                           " (expected mesh, sphere, quadric, bezier or nurbs)");
            }
            const Json* name = Find(v, "name");
            scene_.objects.push_back({name ? String(*name, "name", context) : defaultName});
        }
    }

    // Loads a mesh object; returns its default name (the file's name).
    std::string Mesh(const Json& v, const std::string& context, uint32_t index) {
        const Json& fileValue = Require(v, "file", context);
        const fs::path path = file_.parent_path() / String(fileValue, "file", context);
        std::optional<uint32_t> material;
        if (const Json* e = Find(v, "material")) material = MaterialNamed(*e, context);
        const glm::mat4 toWorld = Transform(v, context);
        const FileText obj = ReadFile(path);
        if (!obj.problem.empty()) {
            Fail(fileValue, context + ": mesh " + Quoted(path.string()) + ": " + obj.problem);
        }
        const ObjMesh mesh = ParseObj(obj.text, path);
        std::optional<uint32_t> far;
        try {
            far = AppendMesh(scene_, mesh, toWorld, material, index);
        } catch (const std::length_error& e) {
            Fail(fileValue,
                 context + ": mesh " + Quoted(path.string()) + ": the scene has " + e.what());
        }
        if (far) {
            const Json* t = Find(v, "transform");
            Fail(t ? *t : fileValue, context + ": mesh " + Quoted(path.string()) + ": vertex " +
                                         std::to_string(*far + 1) + " (line " +
                                         std::to_string(StatementLine(obj.text, "v", *far)) +
                                         ") is out of range after the transform (magnitude above " +
                                         MaxCoordinateText() + ")");
        }
        return path.filename().string();
    }

    // Loads a bezier object from its .bpt file or inline patches; returns the file's name, or
    // empty for inline patches.
    std::string Bezier(const Json& v, const std::string& context, uint32_t index) {
        const Json* fileValue = Find(v, "file");
        const Json* inline_ = Find(v, "patches");
        if ((fileValue != nullptr) == (inline_ != nullptr)) {
            Fail(v, context + ": a bezier object needs either 'file' or 'patches'");
        }
        std::vector<BezierNet> nets;
        std::string name;
        if (fileValue) {
            if (Find(v, "degree")) {
                Fail(*Find(v, "degree"), context + ": 'degree' is given per patch in the file");
            }
            const fs::path path = file_.parent_path() / String(*fileValue, "file", context);
            const FileText bpt = ReadFile(path);
            if (!bpt.problem.empty()) {
                Fail(*fileValue,
                     context + ": patches " + Quoted(path.string()) + ": " + bpt.problem);
            }
            nets = ParseBpt(bpt.text, path);
            name = path.filename().string();
        } else {
            int du = 3, dv = 3;
            if (const Json* d = Find(v, "degree")) Degrees(*d, context, du, dv);
            const size_t points = size_t(du + 1) * size_t(dv + 1);
            if (!inline_->is_array() || inline_->empty()) {
                Fail(*inline_, context + ": 'patches' must be a non-empty array of patches");
            }
            for (size_t k = 0; k < inline_->size(); ++k) {
                const Json& patch = (*inline_)[k];
                const std::string what = context + ": patch " + std::to_string(k + 1);
                if (!patch.is_array() || patch.size() != points) {
                    Fail(patch, what + " must be an array of " + std::to_string(points) +
                                    " points for degrees " + std::to_string(du) + " and " +
                                    std::to_string(dv));
                }
                BezierNet net{du, dv, {}};
                for (const Json& p : patch) {
                    const auto n = Numbers(p, 3);
                    if (!n) Fail(p, what + ": a point must be an array of 3 finite numbers");
                    net.p.emplace_back((*n)[0], (*n)[1], (*n)[2], 1.0);
                }
                nets.push_back(std::move(net));
            }
        }
        AddPatches(v, context, index, nets);
        return name;
    }

    void Degrees(const Json& d, const std::string& context, int& du, int& dv) const {
        const auto n = Numbers(d, 2);
        if (!n || (*n)[0] != std::floor((*n)[0]) || (*n)[1] != std::floor((*n)[1]) || (*n)[0] < 1 ||
            (*n)[0] > 3 || (*n)[1] < 1 || (*n)[1] > 3) {
            Fail(d, context + ": 'degree' must be two integers 1..3 (in u and v)");
        }
        du = int((*n)[0]);
        dv = int((*n)[1]);
    }

    void Nurbs(const Json& v, const std::string& context, uint32_t index) {
        scene::Nurbs n;
        Degrees(Require(v, "degree", context), context, n.du, n.dv);
        const Json& knots = Require(v, "knots", context);
        if (!knots.is_array() || knots.size() != 2 || !knots[0].is_array() ||
            !knots[1].is_array()) {
            Fail(knots, context + ": 'knots' must be two arrays of numbers (in u and v)");
        }
        for (int a = 0; a < 2; ++a) {
            for (const Json& k : knots[size_t(a)]) {
                const auto f = Finite(k);
                if (!f) Fail(k, context + ": knots must be finite numbers");
                (a == 0 ? n.knotsU : n.knotsV).push_back(*f);
            }
        }
        const Json& points = Require(v, "points", context);
        const auto count = [](size_t knots, int degree) {
            return knots > size_t(degree) + 1 ? knots - size_t(degree) - 1 : 0;
        };
        const size_t nu = count(n.knotsU.size(), n.du), nv = count(n.knotsV.size(), n.dv);
        for (int a = 0; a < 2; ++a) {
            const std::string problem =
                a == 0 ? KnotProblem(n.knotsU, n.du, nu) : KnotProblem(n.knotsV, n.dv, nv);
            if (!problem.empty()) {
                Fail(knots[size_t(a)],
                     context + ": the knots in " + (a == 0 ? "u " : "v ") + problem);
            }
        }
        if (!points.is_array() || points.size() != nu * nv) {
            Fail(points, context + ": 'points' must hold " + std::to_string(nu) + " x " +
                             std::to_string(nv) + " = " + std::to_string(nu * nv) +
                             " points for these knots and degrees, not " +
                             std::to_string(points.is_array() ? points.size() : 0));
        }
        for (size_t k = 0; k < points.size(); ++k) {
            const auto p = Numbers(points[k], 4);
            const std::string what = context + ": point " + std::to_string(k + 1);
            if (!p) Fail(points[k], what + " must be an array of 4 finite numbers [x, y, z, w]");
            if (!((*p)[3] > 0.0f)) Fail(points[k], what + ": the weight w must be positive");
            const double w = (*p)[3];
            n.p.emplace_back(w * (*p)[0], w * (*p)[1], w * (*p)[2], w);
        }
        AddPatches(v, context, index, NurbsToBezier(n));
    }

    // Adds the nets as bicubic patches in world space (the object's transform, material).
    void AddPatches(const Json& v, const std::string& context, uint32_t index,
                    const std::vector<BezierNet>& nets) {
        uint32_t material = 0;
        if (const Json* e = Find(v, "material")) material = MaterialNamed(*e, context);
        const glm::dmat4 toWorld(Transform(v, context));
        for (const BezierNet& net : nets) {
            Patch patch = ToBicubic(net);
            for (glm::dvec4& h : patch.p) {
                const glm::dvec3 world = glm::dvec3(toWorld * glm::dvec4(glm::dvec3(h) / h.w, 1.0));
                if (!InRange(glm::vec3(world))) {
                    const Json* t = Find(v, "transform");
                    Fail(t ? *t : v, context + ": a control point is out of range after the " +
                                         "transform (magnitude above " + MaxCoordinateText() + ")");
                }
                h = glm::dvec4(world * h.w, h.w);
            }
            patch.material = material;
            patch.object = index;
            scene_.patches.push_back(patch);
        }
    }

    glm::mat4 Transform(const Json& object, const std::string& context) const {
        const Json* t = Find(object, "transform");
        if (!t) return glm::mat4(1.0f);
        RequireObject(*t, context + ": 'transform'");
        CheckKeys(*t, {"translate", "scale", "rotate", "matrix"}, context, "transform");
        if (const Json* m = Find(*t, "matrix")) {
            if (t->size() > 1) {
                Fail(*m, context +
                             ": 'matrix' cannot be combined with 'translate', 'scale' or "
                             "'rotate'");
            }
            const auto n = Numbers(*m, 16);
            if (!n) Fail(*m, context + ": 'matrix' must be an array of 16 finite numbers");
            glm::mat4 result;
            for (int row = 0; row < 4; ++row) {
                for (int col = 0; col < 4; ++col) result[col][row] = (*n)[size_t(row * 4 + col)];
            }
            if (result[0][3] != 0.0f || result[1][3] != 0.0f || result[2][3] != 0.0f ||
                result[3][3] != 1.0f) {
                Fail(*m, context + ": 'matrix' must be affine (last row 0 0 0 1)");
            }
            const float det = glm::determinant(glm::mat3(result));
            if (det == 0.0f || !std::isfinite(det)) {
                Fail(*m, context + ": 'matrix' must be invertible");
            }
            return result;
        }
        glm::mat4 result(1.0f);  // translate * rotate * scale: scale first, translate last
        if (const Json* e = Find(*t, "translate")) {
            result = glm::translate(result, Position(*e, "translate", context));
        }
        if (const Json* r = Find(*t, "rotate")) {
            RequireObject(*r, context + ": 'rotate'");
            CheckKeys(*r, {"axis", "degrees"}, context, "rotate");
            const Json& axisValue = Require(*r, "axis", context + ": 'rotate'");
            const glm::vec3 axis = Vec3(axisValue, "axis", context);
            if (axis == glm::vec3(0.0f)) Fail(axisValue, context + ": 'axis' must not be zero");
            const Json& degreesValue = Require(*r, "degrees", context + ": 'rotate'");
            const auto degrees = Finite(degreesValue);
            if (!degrees) Fail(degreesValue, context + ": 'degrees' must be a finite number");
            // Scaled before normalising: the length of a huge axis overflows.
            const glm::vec3 scaled =
                axis / glm::max(glm::max(std::fabs(axis.x), std::fabs(axis.y)), std::fabs(axis.z));
            result = glm::rotate(result, glm::radians(*degrees), glm::normalize(scaled));
        }
        if (const Json* e = Find(*t, "scale")) {
            glm::vec3 scale(0.0f);
            if (const auto f = Finite(*e)) {
                scale = glm::vec3(*f);
            } else if (const auto n = Numbers(*e, 3)) {
                scale = glm::vec3((*n)[0], (*n)[1], (*n)[2]);
            }
            if (scale.x == 0.0f || scale.y == 0.0f || scale.z == 0.0f) {
                Fail(*e, context + ": 'scale' must be a non-zero finite number or an array of 3");
            }
            result = glm::scale(result, scale);
        }
        return result;
    }

    Camera ReadCamera(const Json& v) const {
        const std::string context = "camera";
        RequireObject(v, "scene: 'camera'");
        CheckKeys(v, {"position", "look_at", "up", "fov_y", "width", "height", "path"}, context);
        Camera c;
        if (const Json* e = Find(v, "position")) c.position = Position(*e, "position", context);
        if (const Json* e = Find(v, "look_at")) c.lookAt = Position(*e, "look_at", context);
        if (const Json* e = Find(v, "up")) {
            c.up = Vec3(*e, "up", context);
            // Only its direction matters; scaled so that a huge one cannot overflow.
            const float largest =
                glm::max(glm::max(std::fabs(c.up.x), std::fabs(c.up.y)), std::fabs(c.up.z));
            if (largest > 0.0f) c.up /= largest;
        }
        if (const Json* e = Find(v, "fov_y")) {
            const auto f = Finite(*e);
            if (!f || *f <= 0.0f || *f >= 180.0f) {
                Fail(*e, "camera: 'fov_y' must be a number between 0 and 180 (exclusive)");
            }
            c.fovYDegrees = *f;
        }
        const auto side = [&](const char* key, uint32_t& out) {
            const Json* e = Find(v, key);
            if (!e) return;
            // nlohmann stores every non-negative integer literal as unsigned.
            if (!e->is_number_unsigned() || e->get<uint64_t>() < 1 ||
                e->get<uint64_t>() > kMaxImageSide) {
                Fail(*e, "camera: " + Quoted(key) + " must be an integer in 1.." +
                             std::to_string(kMaxImageSide));
            }
            out = uint32_t(e->get<uint64_t>());
        };
        side("width", c.width);
        side("height", c.height);
        const glm::vec3 view = c.lookAt - c.position;
        if (glm::length(view) == 0.0f) Fail(v, "camera: 'look_at' must differ from 'position'");
        if (glm::length(glm::cross(view, c.up)) == 0.0f) {
            Fail(v, "camera: 'up' must not be zero or parallel to the view direction");
        }
        return c;
    }

    // "path": {"interpolation": "linear" | "catmull-rom", "fps": F, "keyframes": [{"time": T,
    // "position": P, "look_at": L}, ...]}: at least two keyframes, times strictly increasing.
    CameraPath ReadCameraPath(const Json& v) const {
        const std::string context = "camera path";
        RequireObject(v, "camera: 'path'");
        CheckKeys(v, {"interpolation", "fps", "keyframes"}, context);
        CameraPath path;
        if (const Json* e = Find(v, "interpolation")) {
            if (*e == "linear") {
                path.interpolation = Interpolation::kLinear;
            } else if (*e == "catmull-rom") {
                path.interpolation = Interpolation::kCatmullRom;
            } else {
                Fail(*e, context + ": 'interpolation' must be \"linear\" or \"catmull-rom\"");
            }
        }
        if (const Json* e = Find(v, "fps")) {
            const auto f = Finite(*e);
            if (!f || *f <= 0.0f || *f > 1e6f) {
                Fail(*e, context + ": 'fps' must be a number in (0, 1e6]");
            }
            path.fps = *f;
        }
        const Json& keys = Require(v, "keyframes", context);
        if (!keys.is_array() || keys.size() < 2) {
            Fail(keys, context + ": 'keyframes' must be an array of at least 2 keyframes");
        }
        for (const Json& k : keys) {
            const std::string where =
                "camera path keyframe " + std::to_string(path.keyframes.size() + 1);
            RequireObject(k, where);
            CheckKeys(k, {"time", "position", "look_at"}, where);
            Keyframe key;
            const Json& time = Require(k, "time", where);
            const auto t = Finite(time);
            if (!t || std::fabs(*t) > 1e9f) Fail(time, where + ": 'time' must be a finite number");
            if (!path.keyframes.empty() && !(*t > path.keyframes.back().time)) {
                Fail(time, where + ": 'time' must be later than the keyframe before");
            }
            key.time = *t;
            key.position = Position(Require(k, "position", where), "position", where);
            key.lookAt = Position(Require(k, "look_at", where), "look_at", where);
            if (key.lookAt == key.position)
                Fail(k, where + ": 'look_at' must differ from 'position'");
            path.keyframes.push_back(key);
        }
        return path;
    }

    const fs::path& file_;
    std::string_view text_;
    Scene scene_;
    std::unordered_map<const Json*, int> line_;
};

Scene LoadBareObj(const fs::path& file) {
    Scene scene;
    const FileText obj = ReadFile(file);
    if (!obj.problem.empty()) throw SceneError(file.string(), 0, obj.problem);
    if (const auto far =
            AppendMesh(scene, ParseObj(obj.text, file), glm::mat4(1.0f), std::nullopt, 0)) {
        throw SceneError(file.string(), StatementLine(obj.text, "v", *far),
                         "vertex " + std::to_string(*far + 1) +
                             " is out of range (magnitude above " + MaxCoordinateText() + ")");
    }
    scene.objects.push_back({file.filename().string()});
    const Bounds3f bounds = scene.Bounds();
    if (bounds.Empty()) throw SceneError(file.string(), 0, "no triangles to render");
    scene.camera = FramingCamera(bounds, 800, 600);
    // Irradiance intensity / distance^2 is 1 on a surface at the framing distance.
    const float distance = glm::length(scene.camera.position - scene.camera.lookAt);
    scene.lights.push_back({scene.camera.position, glm::vec3(distance * distance)});
    scene.ambient = glm::vec3(0.05f);
    return scene;
}

}  // namespace

Scene LoadScene(const fs::path& file) {
    const std::string extension = Lowercase(file.extension().string());
    if (extension == ".obj") return LoadBareObj(file);
    if (extension != ".json") {
        throw SceneError(file.string(), 0,
                         "unknown scene file extension " + Quoted(file.extension().string()) +
                             " (expected .json or .obj)");
    }
    const FileText json = ReadFile(file);
    if (!json.problem.empty()) throw SceneError(file.string(), 0, json.problem);
    return LoadSceneText(json.text, file);
}

Scene LoadSceneText(std::string_view text, const fs::path& file) {
    return SceneFileReader(file, text).Read();
}

}  // namespace rayclass::scene
