// The scene as every renderer sees it: world-space primitives (triangles, analytic spheres and
// clipped quadrics), Whitted materials, point lights and a pinhole camera. Loaders (OBJ, JSON)
// produce it; renderers and the classifier only read it.
//
// Primitive ids are global and ordered: triangles [0, nT), spheres [nT, nT + nS), quadrics, then
// patch boxes.
#pragma once

#include <array>
#include <cstdint>
#include <glm/glm.hpp>
#include <string>
#include <vector>

#include "rayclass/core/bounds.h"
#include "rayclass/scene/camera_path.h"

namespace rayclass::scene {

struct Material {
    std::string name = "default";
    glm::vec3 kd{0.75f};       // Phong diffuse
    glm::vec3 ks{0.0f};        // Phong specular
    float shininess = 32.0f;   // Phong exponent
    glm::vec3 kr{0.0f};        // mirror reflection
    glm::vec3 kt{0.0f};        // transmission
    float ior = 1.5f;          // index of refraction of the inside
    bool fresnel = false;      // weight kt's reflected share by the dielectric Fresnel term
    glm::vec3 emission{0.0f};  // radiance the surface adds itself
};

// Largest coordinate magnitude (positions, radii, transformed vertices) a scene may use: the
// triangle test's cubic products (edge x edge . offset) stay finite in float up to
// (3.4e38)^(1/3) ~ 7e12. The loaders refuse larger values rather than render infinities.
inline constexpr float kMaxCoordinate = 1e12f;

struct Triangle {
    std::array<glm::vec3, 3> p;  // vertices, world space
    std::array<glm::vec3, 3> n;  // unit vertex normals, valid when hasNormals
    bool hasNormals = false;
    uint32_t material = 0;
    uint32_t object = 0;
};

struct Sphere {
    glm::vec3 center{0.0f};
    float radius = 1.0f;
    uint32_t material = 0;
    uint32_t object = 0;
};

// A x^2 + B y^2 + C z^2 + D xy + E xz + F yz + G x + H y + I z + J = 0, coefficients in that
// order, clipped to [boxMin, boxMax] (world space). Only hits inside the box count.
struct Quadric {
    std::array<float, 10> c{};
    glm::vec3 boxMin{-1.0f};
    glm::vec3 boxMax{1.0f};
    uint32_t material = 0;
    uint32_t object = 0;
};

// A rational bicubic Bezier patch: 16 control points in homogeneous form (w x, w y, w z, w > 0);
// p[4 i + j] weighs B_i(u) B_j(v). Lower degrees are raised to 3 on load (scene/patch.h).
struct Patch {
    std::array<glm::dvec4, 16> p;
    uint32_t material = 0;
    uint32_t object = 0;
};

// The primitive the queries see of a patch: its part [u0, u1] x [v0, v1] as a patch of its own
// (control points p, local parameters [0, 1]^2) and the box of those control points, which holds
// the surface (convex hull). closedU: the part reaches u = 1 of its patch, so its local u = 1
// belongs to it (elsewhere the next box owns that edge); closedV alike.
struct PatchBox {
    std::array<glm::dvec4, 16> p;
    Bounds3f bounds;
    uint32_t patch = 0;
    glm::dvec2 u{0.0, 1.0}, v{0.0, 1.0};
    bool closedU = true, closedV = true;
};

struct PointLight {
    glm::vec3 position{0.0f};
    glm::vec3 intensity{1.0f};  // rgb; irradiance falls off as intensity / distance^2
};

struct Camera {
    glm::vec3 position{0.0f, 0.0f, 1.0f};
    glm::vec3 lookAt{0.0f};
    glm::vec3 up{0.0f, 1.0f, 0.0f};
    float fovYDegrees = 45.0f;
    uint32_t width = 800;
    uint32_t height = 600;
};

// An object of the scene file (a mesh, a sphere, a quadric) for the object-id AOV and messages.
struct Object {
    std::string name;
};

struct Scene {
    Camera camera;
    CameraPath cameraPath;                        // the camera's animation, if any (camera "path")
    std::vector<Material> materials{Material{}};  // index 0 is the default material
    std::vector<Triangle> triangles;
    std::vector<Sphere> spheres;
    std::vector<Quadric> quadrics;
    std::vector<Patch> patches;
    std::vector<PatchBox> patchBoxes;  // scene/patch.h SplitPatches
    float patchFlatness = 0.2f;        // see scene/patch.h PatchSplit
    std::vector<PointLight> lights;
    std::vector<Object> objects;
    glm::vec3 ambient{0.0f};     // ambient light, times kd
    glm::vec3 background{0.0f};  // radiance of rays that leave the scene

    uint32_t PrimitiveCount() const {
        return uint32_t(triangles.size() + spheres.size() + quadrics.size() + patchBoxes.size());
    }
    uint32_t SphereBase() const { return uint32_t(triangles.size()); }
    uint32_t QuadricBase() const { return uint32_t(triangles.size() + spheres.size()); }
    uint32_t PatchBoxBase() const { return QuadricBase() + uint32_t(quadrics.size()); }

    // Box of every primitive (quadrics by their clip box, patch boxes by their control points).
    Bounds3f Bounds() const;
    // Box of primitive `id` (global id).
    Bounds3f PrimitiveBounds(uint32_t id) const;
};

// A camera that frames `box` from the front (+z side, looking along -z, y up) with a vertical
// field of view of 45 degrees; used when a bare OBJ is rendered.
Camera FramingCamera(const Bounds3f& box, uint32_t width, uint32_t height);

}  // namespace rayclass::scene
