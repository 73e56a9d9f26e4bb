#include "raysets.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <stdexcept>

#include "rayclass/geometry/intersect.h"
#include "rayclass/render/device_scene.h"

namespace rayclass::bench {

scene::Camera NamedCamera(const scene::Scene& scene, const std::string& name, uint32_t width,
                          uint32_t height) {
    scene::Camera c = scene.camera;
    c.width = width;
    c.height = height;
    const Bounds3f box = scene.Bounds();
    if (name == "scene") return c;
    if (name == "orbit") {
        const glm::vec3 rel = c.position - c.lookAt;
        const float a = glm::radians(40.0f), ca = std::cos(a), sa = std::sin(a);
        c.position = c.lookAt + glm::vec3(ca * rel.x + sa * rel.z, rel.y, -sa * rel.x + ca * rel.z);
        return c;
    }
    if (name == "anchor" || name == "reverse") {
        const float sx = box.Size().x, sy = box.Size().y;
        const float s = name == "anchor" ? 1.0f : -1.0f;
        c.position = box.Center() - s * glm::vec3(0.25f * sx, 0.0f, 0.0f);
        if (name == "reverse") c.position.y += 0.1f * sy;
        c.lookAt = c.position + glm::vec3(s, 0.0f, 0.0f);
        c.up = glm::vec3(0.0f, 1.0f, 0.0f);
        c.fovYDegrees = 60.0f;
        return c;
    }
    throw std::invalid_argument("unknown camera '" + name + "' (scene, orbit, anchor or reverse)");
}

glm::vec3 NamedLight(const scene::Scene& scene, const std::string& spec) {
    if (spec == "scene") {
        if (scene.lights.empty()) throw std::invalid_argument("the scene has no light");
        return scene.lights[0].position;
    }
    if (spec.rfind("anchor:", 0) == 0) {
        const float f = std::stof(spec.substr(7));
        const Bounds3f box = scene.Bounds();
        return box.Center() + f * box.Size().y * glm::vec3(0.0f, 1.0f, 0.0f);
    }
    throw std::invalid_argument("unknown light '" + spec + "' (scene or anchor:F)");
}

std::vector<BenchRay> EyeRays(const scene::Camera& camera) {
    const render::CameraBasis basis(camera);
    std::vector<BenchRay> rays;
    rays.reserve(size_t(basis.width) * basis.height);
    for (uint32_t y = 0; y < basis.height; ++y) {
        for (uint32_t x = 0; x < basis.width; ++x) {
            BenchRay ray;
            ray.origin = glm::vec3(basis.position);
            ray.tMin = 0.0f;
            ray.direction = basis.DirectionFloat(x, y);
            ray.tMax = INFINITY;
            rays.push_back(ray);
        }
    }
    return rays;
}

RaySets MakeRaySets(const scene::Scene& scene, const std::vector<BenchRay>& eye,
                    const std::vector<BenchHit>& hits, const glm::vec3& light, uint32_t seed,
                    uint32_t width) {
    RaySets out;
    out.width = width;
    out.sets[0] = eye;
    for (size_t i = 0; i < eye.size(); ++i) out.pixels[0].push_back(uint32_t(i));
    const float offset = 1e-4f * scene.Bounds().Diagonal();
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> uni(0.0f, 1.0f);
    constexpr float kIor = 1.5f;
    for (size_t i = 0; i < eye.size(); ++i) {
        if (hits[i].prim == 0xFFFFFFFFu) continue;
        const glm::vec3 d = eye[i].direction;
        const glm::vec3 p = eye[i].origin + hits[i].t * d;
        glm::vec3 n =
            geometry::GeometricNormal(scene, hits[i].prim, p, glm::vec2(hits[i].u, hits[i].v));
        if (!(glm::length(n) > 0.0f)) continue;
        n = glm::normalize(n);
        if (glm::dot(n, d) > 0.0f) n = -n;  // facing the eye
        const glm::vec3 front = p + offset * n, back = p - offset * n;
        // Shadow: from the side facing the light to the light (the segment ends there, as the
        // renderer's shadow rays do).
        {
            const glm::vec3 toLight = light - p;
            if (glm::length(toLight) > 0.0f) {
                BenchRay s;
                s.origin = glm::dot(toLight, n) >= 0.0f ? front : back;
                const glm::vec3 toLightFromOrigin = light - s.origin;
                s.tMax = glm::length(toLightFromOrigin);
                s.direction = toLightFromOrigin / s.tMax;
                out.sets[1].push_back(s);
                out.pixels[1].push_back(uint32_t(i));
            }
        }
        BenchRay m;
        m.origin = front;
        m.direction = glm::normalize(d - 2.0f * glm::dot(d, n) * n);
        m.tMax = INFINITY;
        out.sets[2].push_back(m);
        out.pixels[2].push_back(uint32_t(i));
        // Refraction into glass (n faces the incoming ray): Snell with eta = 1 / ior.
        {
            const float eta = 1.0f / kIor, cosi = -glm::dot(d, n);
            const float k = 1.0f - eta * eta * (1.0f - cosi * cosi);
            if (k >= 0.0f) {
                BenchRay t;
                t.origin = back;
                t.direction = glm::normalize(eta * d + (eta * cosi - std::sqrt(k)) * n);
                t.tMax = INFINITY;
                out.sets[3].push_back(t);
                out.pixels[3].push_back(uint32_t(i));
            }
        }
        // Cosine-distributed about n (Malley's method on an orthonormal basis of n).
        {
            const float u1 = uni(rng), u2 = uni(rng);
            const float r = std::sqrt(u1), phi = 6.28318530718f * u2;
            const glm::vec3 a = std::abs(n.x) > 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
            const glm::vec3 b1 = glm::normalize(glm::cross(n, a)), b2 = glm::cross(n, b1);
            const float z = std::sqrt(std::max(0.0f, 1.0f - u1));
            BenchRay g;
            g.origin = front;
            g.direction = glm::normalize(r * std::cos(phi) * b1 + r * std::sin(phi) * b2 + z * n);
            g.tMax = INFINITY;
            out.sets[4].push_back(g);
            out.pixels[4].push_back(uint32_t(i));
        }
    }
    return out;
}

void SaveRaySets(const std::filesystem::path& file, const RaySets& sets) {
    std::ofstream f(file, std::ios::binary);
    if (!f) throw std::runtime_error("cannot write " + file.string());
    f.write("RCRAYS2", 8);
    f.write(reinterpret_cast<const char*>(&sets.width), sizeof sets.width);
    for (const auto& s : sets.sets) {
        const uint64_t n = s.size();
        f.write(reinterpret_cast<const char*>(&n), sizeof n);
    }
    for (const auto& s : sets.sets) {
        f.write(reinterpret_cast<const char*>(s.data()),
                std::streamsize(s.size() * sizeof(BenchRay)));
    }
    for (const auto& p : sets.pixels) {
        f.write(reinterpret_cast<const char*>(p.data()),
                std::streamsize(p.size() * sizeof(uint32_t)));
    }
    if (!f) throw std::runtime_error("error writing " + file.string());
}

RaySets LoadRaySets(const std::filesystem::path& file) {
    std::ifstream f(file, std::ios::binary);
    char magic[8];
    if (!f.read(magic, 8) || std::memcmp(magic, "RCRAYS2", 8) != 0) {
        throw std::runtime_error(file.string() + ": not a ray-set file (RCRAYS2)");
    }
    RaySets sets;
    f.read(reinterpret_cast<char*>(&sets.width), sizeof sets.width);
    uint64_t counts[kNumKinds];
    f.read(reinterpret_cast<char*>(counts), sizeof counts);
    for (int k = 0; k < kNumKinds; ++k) {
        sets.sets[k].resize(counts[k]);
        f.read(reinterpret_cast<char*>(sets.sets[k].data()),
               std::streamsize(counts[k] * sizeof(BenchRay)));
    }
    for (int k = 0; k < kNumKinds; ++k) {
        sets.pixels[k].resize(counts[k]);
        f.read(reinterpret_cast<char*>(sets.pixels[k].data()),
               std::streamsize(counts[k] * sizeof(uint32_t)));
    }
    if (!f) throw std::runtime_error(file.string() + ": truncated");
    return sets;
}

}  // namespace rayclass::bench
