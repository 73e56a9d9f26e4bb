#include "rayclass/render/device_scene.h"

#include <cmath>
#include <limits>

#include "rayclass/core/error.h"

namespace rayclass::render {

namespace {

rc_float4 F4(const glm::vec3& v, float w = 0.0f) { return {v.x, v.y, v.z, w}; }

}  // namespace

CameraBasis::CameraBasis(const scene::Camera& camera, const std::optional<image::PixelRect>& crop)
    : position(camera.position),
      width(camera.width),
      height(camera.height),
      window(crop.value_or(image::PixelRect{0, 0, width, height})) {
    if (window.Empty() || !window.Inside(width, height)) {
        throw Error("crop " + window.ToString() + " is not a non-empty part of the " +
                    std::to_string(width) + "x" + std::to_string(height) + " image");
    }
    forward = glm::normalize(glm::dvec3(camera.lookAt) - position);
    right = glm::normalize(glm::cross(forward, glm::dvec3(camera.up)));
    up = glm::cross(right, forward);
    tanHalfFovY = std::tan(glm::radians(double(camera.fovYDegrees)) * 0.5);
    tanHalfFovX = tanHalfFovY * double(width) / double(height);
}

glm::dvec3 CameraBasis::Direction(uint32_t x, uint32_t y) const {
    const double sx = (2.0 * (x + 0.5) / width - 1.0) * tanHalfFovX;
    const double sy = (1.0 - 2.0 * (y + 0.5) / height) * tanHalfFovY;
    return glm::normalize(forward + sx * right + sy * up);
}

glm::vec3 CameraBasis::DirectionFloat(uint32_t x, uint32_t y) const {
    const glm::vec3 f(forward), r(right), u(up);
    const float sx = (2.0f * (float(x) + 0.5f) / float(width) - 1.0f) * float(tanHalfFovX);
    const float sy = (1.0f - 2.0f * (float(y) + 0.5f) / float(height)) * float(tanHalfFovY);
    return glm::normalize(f + sx * r + sy * u);
}

RcCamera CameraBasis::ToDevice() const {
    RcCamera c{};
    c.position = F4(glm::vec3(position));
    c.forward = F4(glm::vec3(forward));
    c.right = F4(glm::vec3(right));
    c.up = F4(glm::vec3(up));
    c.tanHalfFovX = float(tanHalfFovX);
    c.tanHalfFovY = float(tanHalfFovY);
    c.width = width;
    c.height = height;
    c.windowX = window.x0;
    c.windowY = window.y0;
    c.windowWidth = window.Width();
    c.windowHeight = window.Height();
    return c;
}

image::Image NewImage(const CameraBasis& basis, bool aovs) {
    image::Image img(basis.window.Width(), basis.window.Height());
    img.originX = basis.window.x0;
    img.originY = basis.window.y0;
    img.displayWidth = basis.width;
    img.displayHeight = basis.height;
    if (aovs) {
        img.depth.assign(img.PixelCount(), std::numeric_limits<float>::infinity());
        img.id.assign(img.PixelCount(), RC_NO_HIT);
        img.normal.assign(img.PixelCount(), glm::vec3(0.0f));
    }
    return img;
}

RcTriangle ToDevice(const scene::Triangle& t) { return {F4(t.p[0]), F4(t.p[1]), F4(t.p[2])}; }

RcTriangleShading ShadingOf(const scene::Triangle& t) {
    RcTriangleShading s{};
    if (t.hasNormals) {
        s.n0 = F4(t.n[0]);
        s.n1 = F4(t.n[1]);
        s.n2 = F4(t.n[2]);
    }
    s.material = t.material;
    s.object = t.object;
    s.hasNormals = t.hasNormals ? 1u : 0u;
    return s;
}

RcSphere ToDevice(const scene::Sphere& s) {
    RcSphere d{};
    d.centerRadius = F4(s.center, s.radius);
    d.material = s.material;
    d.object = s.object;
    return d;
}

RcQuadric ToDevice(const scene::Quadric& q) {
    RcQuadric d{};
    d.c0 = {q.c[0], q.c[1], q.c[2], q.c[3]};
    d.c1 = {q.c[4], q.c[5], q.c[6], q.c[7]};
    d.c2 = {q.c[8], q.c[9], 0.0f, 0.0f};
    d.boxMin = F4(q.boxMin);
    d.boxMax = F4(q.boxMax);
    d.material = q.material;
    d.object = q.object;
    return d;
}

RcMaterial ToDevice(const scene::Material& m) {
    RcMaterial d{};
    d.kd = F4(m.kd);
    d.ks = F4(m.ks);
    d.kr = F4(m.kr);
    d.kt = F4(m.kt);
    d.emission = F4(m.emission);
    d.shininess = m.shininess;
    d.ior = m.ior;
    d.fresnel = m.fresnel ? 1u : 0u;
    return d;
}

RcLight ToDevice(const scene::PointLight& l) { return {F4(l.position), F4(l.intensity)}; }

}  // namespace rayclass::render
