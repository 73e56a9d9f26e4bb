#include "render_hash.h"

#include <cstdint>
#include <cstdio>
#include <type_traits>

namespace rayclass::cli {

namespace {

class Fnv1a {
  public:
    template <typename T>
    void Add(const T& value) {
        static_assert(std::is_arithmetic_v<T> || std::is_enum_v<T>);
        const auto* bytes = reinterpret_cast<const unsigned char*>(&value);
        for (size_t i = 0; i < sizeof(T); ++i) {
            hash_ = (hash_ ^ bytes[i]) * 0x100000001b3ull;
        }
    }
    void Add(const glm::vec3& v) {
        Add(v.x);
        Add(v.y);
        Add(v.z);
    }
    void Add(const glm::dvec4& v) {
        for (int k = 0; k < 4; ++k) Add(v[k]);
    }
    uint64_t Value() const { return hash_; }

  private:
    uint64_t hash_ = 0xcbf29ce484222325ull;
};

void AddScene(Fnv1a& h, const scene::Scene& s) {
    const scene::Camera& c = s.camera;
    h.Add(c.position);
    h.Add(c.lookAt);
    h.Add(c.up);
    h.Add(c.fovYDegrees);
    h.Add(c.width);
    h.Add(c.height);
    h.Add(s.materials.size());
    for (const scene::Material& m : s.materials) {
        for (const glm::vec3& v : {m.kd, m.ks, m.kr, m.kt, m.emission}) h.Add(v);
        h.Add(m.shininess);
        h.Add(m.ior);
        h.Add(m.fresnel);
    }
    h.Add(s.triangles.size());
    for (const scene::Triangle& t : s.triangles) {
        for (int k = 0; k < 3; ++k) h.Add(t.p[k]);
        if (t.hasNormals) {
            for (int k = 0; k < 3; ++k) h.Add(t.n[k]);
        }
        h.Add(t.hasNormals);
        h.Add(t.material);
        h.Add(t.object);
    }
    h.Add(s.spheres.size());
    for (const scene::Sphere& sp : s.spheres) {
        h.Add(sp.center);
        h.Add(sp.radius);
        h.Add(sp.material);
        h.Add(sp.object);
    }
    h.Add(s.quadrics.size());
    for (const scene::Quadric& q : s.quadrics) {
        for (float k : q.c) h.Add(k);
        h.Add(q.boxMin);
        h.Add(q.boxMax);
        h.Add(q.material);
        h.Add(q.object);
    }
    // The patches and the boxes they were split into: --patch-boxes and the flatness change the
    // boxes, and with them the hits.
    h.Add(s.patches.size());
    for (const scene::Patch& pt : s.patches) {
        for (const glm::dvec4& c : pt.p) h.Add(c);
        h.Add(pt.material);
        h.Add(pt.object);
    }
    h.Add(s.patchBoxes.size());
    for (const scene::PatchBox& b : s.patchBoxes) {
        h.Add(b.patch);
        for (double k : {b.u.x, b.u.y, b.v.x, b.v.y}) h.Add(k);
        h.Add(b.closedU);
        h.Add(b.closedV);
    }
    h.Add(s.lights.size());
    for (const scene::PointLight& l : s.lights) {
        h.Add(l.position);
        h.Add(l.intensity);
    }
    h.Add(s.ambient);
    h.Add(s.background);
}

}  // namespace

std::string RenderHash(const scene::Scene& scene, const render::RenderOptions& options,
                       bool reference) {
    Fnv1a h;
    AddScene(h, scene);
    h.Add(options.maxDepth);
    h.Add(options.minWeight);
    h.Add(options.triangleTest);
    h.Add(options.rayEncoding);
    h.Add(reference);
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h.Value()));
    return hex;
}

}  // namespace rayclass::cli
