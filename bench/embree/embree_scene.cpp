#include "embree_scene.h"

#include <chrono>
#include <cmath>
#include <string>

#include "rayclass/core/error.h"
#include "rayclass/geometry/intersect.h"

namespace rayclass::bench {

namespace {

void Check(RTCDevice device, const char* what) {
    const RTCError e = rtcGetDeviceError(device);
    if (e != RTC_ERROR_NONE)
        throw Error(std::string("Embree: ") + what + " failed, error " + std::to_string(int(e)));
}

void SetBounds(RTCBounds* b, const glm::vec3& lo, const glm::vec3& hi) {
    b->lower_x = lo.x;
    b->lower_y = lo.y;
    b->lower_z = lo.z;
    b->upper_x = hi.x;
    b->upper_y = hi.y;
    b->upper_z = hi.z;
}

void SphereBounds(const RTCBoundsFunctionArguments* args) {
    const auto& s = static_cast<const scene::Scene*>(args->geometryUserPtr)->spheres[args->primID];
    SetBounds(args->bounds_o, s.center - glm::vec3(s.radius), s.center + glm::vec3(s.radius));
}

void QuadricBounds(const RTCBoundsFunctionArguments* args) {
    const auto& q = static_cast<const scene::Scene*>(args->geometryUserPtr)->quadrics[args->primID];
    SetBounds(args->bounds_o, q.boxMin, q.boxMax);
}

geometry::Ray<float> LaneRay(RTCRayN* ray, unsigned n, unsigned i) {
    geometry::Ray<float> r;
    r.o = {RTCRayN_org_x(ray, n, i), RTCRayN_org_y(ray, n, i), RTCRayN_org_z(ray, n, i)};
    r.d = {RTCRayN_dir_x(ray, n, i), RTCRayN_dir_y(ray, n, i), RTCRayN_dir_z(ray, n, i)};
    r.tMin = RTCRayN_tnear(ray, n, i);
    r.tMax = RTCRayN_tfar(ray, n, i);
    return r;
}

// The hit distance of primitive `prim` of the user geometry behind `geometryUserPtr`, by
// rayclass's float routines.
template <bool kSphere>
bool Hit(const void* userPtr, unsigned prim, const geometry::Ray<float>& r, float& t) {
    const auto& sc = *static_cast<const scene::Scene*>(userPtr);
    if constexpr (kSphere) {
        const auto& s = sc.spheres[prim];
        return geometry::IntersectSphere(r, s.center, s.radius, t);
    } else {
        const auto& q = sc.quadrics[prim];
        return geometry::IntersectQuadric(r, geometry::QuadricCoefficients<float>(q), q.boxMin,
                                          q.boxMax, t);
    }
}

template <bool kSphere>
void Intersect(const RTCIntersectFunctionNArguments* args) {
    RTCRayN* ray = RTCRayHitN_RayN(args->rayhit, args->N);
    RTCHitN* hit = RTCRayHitN_HitN(args->rayhit, args->N);
    for (unsigned i = 0; i < args->N; ++i) {
        if (!args->valid[i]) continue;
        const geometry::Ray<float> r = LaneRay(ray, args->N, i);
        float t = 0;
        if (!Hit<kSphere>(args->geometryUserPtr, args->primID, r, t)) continue;
        // The shading recomputes the normal from the primitive; Ng is the radius vector or the
        // gradient for a caller that reads it.
        const auto& sc = *static_cast<const scene::Scene*>(args->geometryUserPtr);
        const uint32_t base = kSphere ? sc.SphereBase() : sc.QuadricBase();
        const glm::vec3 ng = geometry::GeometricNormal(sc, base + args->primID, r.o + t * r.d);
        RTCRayN_tfar(ray, args->N, i) = t;
        RTCHitN_Ng_x(hit, args->N, i) = ng.x;
        RTCHitN_Ng_y(hit, args->N, i) = ng.y;
        RTCHitN_Ng_z(hit, args->N, i) = ng.z;
        RTCHitN_u(hit, args->N, i) = 0.0f;
        RTCHitN_v(hit, args->N, i) = 0.0f;
        RTCHitN_primID(hit, args->N, i) = args->primID;
        RTCHitN_geomID(hit, args->N, i) = args->geomID;
        RTCHitN_instID(hit, args->N, i, 0) = args->context->instID[0];
    }
}

template <bool kSphere>
void Occluded(const RTCOccludedFunctionNArguments* args) {
    for (unsigned i = 0; i < args->N; ++i) {
        if (!args->valid[i]) continue;
        float t = 0;
        if (Hit<kSphere>(args->geometryUserPtr, args->primID, LaneRay(args->ray, args->N, i), t)) {
            RTCRayN_tfar(args->ray, args->N, i) = -INFINITY;
        }
    }
}

template <bool kSphere>
void AttachUser(RTCDevice device, RTCScene scene, const scene::Scene& sc, size_t count,
                unsigned id) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(g, unsigned(count));
    rtcSetGeometryUserData(g, const_cast<scene::Scene*>(&sc));
    rtcSetGeometryBoundsFunction(g, kSphere ? SphereBounds : QuadricBounds, nullptr);
    rtcSetGeometryIntersectFunction(g, Intersect<kSphere>);
    rtcSetGeometryOccludedFunction(g, Occluded<kSphere>);
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(scene, g, id);
    rtcReleaseGeometry(g);
    Check(device, "user geometry");
}

void AttachTriangles(RTCDevice device, RTCScene scene, const scene::Scene& sc) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    const size_t n = sc.triangles.size();
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * n));
    auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), n));
    Check(device, "triangle buffers");
    for (size_t t = 0; t < n; ++t) {
        for (int k = 0; k < 3; ++k) {
            const glm::vec3& p = sc.triangles[t].p[k];
            v[9 * t + 3 * k] = p.x;
            v[9 * t + 3 * k + 1] = p.y;
            v[9 * t + 3 * k + 2] = p.z;
            idx[3 * t + k] = unsigned(3 * t + k);
        }
    }
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(scene, g, EmbreeScene::kTriangles);
    rtcReleaseGeometry(g);
    Check(device, "triangles");
}

}  // namespace

EmbreeScene::EmbreeScene(const scene::Scene& sc, int threads)
    : sphereBase_(sc.SphereBase()), quadricBase_(sc.QuadricBase()) {
    if (!sc.patchBoxes.empty()) {
        throw Error("the Embree peer takes triangles, spheres and quadrics; this scene has " +
                    std::to_string(sc.patches.size()) + " Bezier patches");
    }
    const std::string config = "threads=" + std::to_string(threads);
    device_.reset(rtcNewDevice(config.c_str()));
    if (!device_) throw Error("Embree: rtcNewDevice failed");
    RTCDevice device = device_.get();
    const auto t0 = std::chrono::steady_clock::now();
    scene_.reset(rtcNewScene(device));
    Check(device, "rtcNewScene");
    RTCScene scene = scene_.get();
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
    if (!sc.triangles.empty()) AttachTriangles(device, scene, sc);
    if (!sc.spheres.empty()) AttachUser<true>(device, scene, sc, sc.spheres.size(), kSpheres);
    if (!sc.quadrics.empty()) {
        AttachUser<false>(device, scene, sc, sc.quadrics.size(), kQuadrics);
    }
    rtcCommitScene(scene);
    Check(device, "scene build");
    buildSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace rayclass::bench
