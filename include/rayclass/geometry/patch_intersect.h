// Ray-patch intersection on the host, for one patch box (scene::PatchBox):
// - IntersectPatchNewton: the kernels' Newton iteration in float (cl/patch.cl, the same
//   operations in the same order), for host-side queries and tests; the ray direction is unit.
// - IntersectPatchReference: the reference renderer's oracle, by another method in double: the
//   box is halved recursively (de Casteljau) while the ray meets the convex hull of a part's
//   control points, down to parts 1/64 of the box wide each way, and each part the ray still
//   meets is polished by Newton's method in double from its own centre; the nearest root inside
//   the box's own parameter range wins.
#pragma once

#include <array>
#include <cmath>
#include <glm/glm.hpp>

#include "rayclass/scene/patch.h"
#include "rayclass/scene/scene.h"

namespace rayclass::geometry {

// See cl/patch.cl: iteration cap and convergence share.
inline constexpr int kPatchIterations = 12;
inline constexpr float kPatchEps = 1.0f / 262144.0f;

namespace patch_detail {

template <typename T>
void Bernstein3(T s, T* b, T* db) {
    const T r = T(1) - s;
    b[0] = r * r * r;
    b[1] = T(3) * s * r * r;
    b[2] = T(3) * s * s * r;
    b[3] = s * s * s;
    db[0] = T(-3) * r * r;
    db[1] = T(3) * r * (r - T(2) * s);
    db[2] = T(3) * s * (T(2) * r - s);
    db[3] = T(3) * s * s;
}

// Value and the derivatives along s and t of one channel.
template <typename T>
glm::vec<3, T> Channel(const T* c, const T* bu, const T* dbu, const T* bv, const T* dbv) {
    T x = 0, xs = 0, xt = 0;
    for (int i = 0; i < 4; ++i) {
        const T row =
            bv[0] * c[4 * i] + bv[1] * c[4 * i + 1] + bv[2] * c[4 * i + 2] + bv[3] * c[4 * i + 3];
        const T rowD = dbv[0] * c[4 * i] + dbv[1] * c[4 * i + 1] + dbv[2] * c[4 * i + 2] +
                       dbv[3] * c[4 * i + 3];
        x += bu[i] * row;
        xs += dbu[i] * row;
        xt += bu[i] * rowD;
    }
    return {x, xs, xt};
}

template <typename T>
T Dot(const glm::vec<3, T>& a, const glm::vec<3, T>& b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

template <typename T>
void Planes(const glm::vec<3, T>& d, glm::vec<3, T>& n1, glm::vec<3, T>& n2) {
    using V = glm::vec<3, T>;
    V n = std::fabs(d.x) > std::fabs(d.y) && std::fabs(d.x) > std::fabs(d.z) ? V(d.y, -d.x, 0)
                                                                             : V(0, d.z, -d.y);
    n = n / std::sqrt(Dot(n, n));
    n1 = n;
    n2 = V(d.y * n.z - n.y * d.z, d.z * n.x - n.z * d.x, d.x * n.y - n.x * d.y);
}

}  // namespace patch_detail

// Whether a local (s, t) belongs to the box (rc_types.h RcPatchBox).
template <typename T>
bool InPatchBox(T s, T t, bool closedU, bool closedV) {
    return s >= T(0) && (s < T(1) || (closedU && s == T(1))) && t >= T(0) &&
           (t < T(1) || (closedV && t == T(1)));
}

namespace patch_detail {

// cl/patch.cl RC_PATCH_START_S and _T: the box's centre, then its quarters' centres.
inline constexpr int kPatchStarts = 5;
inline float PatchStartS(int k) { return k == 0 ? 0.5f : (k & 1) ? 0.25f : 0.75f; }
inline float PatchStartT(int k) { return k == 0 ? 0.5f : k <= 2 ? 0.25f : 0.75f; }

// cl/patch.cl rc_patch_half_curve: the half towards c3 when `upper`, else towards c0.
inline void HalfCurve(float c0, float c1, float c2, float c3, bool upper, float* q) {
    const float a = 0.5f * (c0 + c1), b = 0.5f * (c1 + c2), d = 0.5f * (c2 + c3);
    const float ab = 0.5f * (a + b), bd = 0.5f * (b + d), m = 0.5f * (ab + bd);
    q[0] = upper ? m : c0;
    q[1] = upper ? bd : a;
    q[2] = upper ? d : ab;
    q[3] = upper ? c3 : m;
}

// cl/patch.cl rc_patch_quarter_straddles: whether channel x takes both signs on the control
// points of the box's quarter (qu, qv).
inline bool QuarterStraddles(const float* x, bool qu, bool qv) {
    float h[16];
    for (int j = 0; j < 4; ++j) {
        float q[4];
        HalfCurve(x[j], x[4 + j], x[8 + j], x[12 + j], qu, q);
        for (int i = 0; i < 4; ++i) h[4 * i + j] = q[i];
    }
    int signs = 0;
    for (int i = 0; i < 4; ++i) {
        float q[4];
        HalfCurve(h[4 * i], h[4 * i + 1], h[4 * i + 2], h[4 * i + 3], qv, q);
        for (int j = 0; j < 4; ++j) signs |= (q[j] >= 0.0f ? 1 : 0) | (q[j] <= 0.0f ? 2 : 0);
    }
    return signs == 3;
}

// cl/patch.cl rc_patch_newton_search: whether the search from (s, t) converged; (s, t) and the
// weights are those of the last point evaluated.
inline bool NewtonSearch(const float* a, const float* b, const float* w, float eps, float& s,
                         float& t, float* bu, float* dbu, float* bv, float* dbv) {
    float prev = INFINITY;
    for (int it = 0;; ++it) {
        Bernstein3(s, bu, dbu);
        Bernstein3(t, bv, dbv);
        const glm::vec3 A = Channel(a, bu, dbu, bv, dbv);
        const glm::vec3 B = Channel(b, bu, dbu, bv, dbv);
        const glm::vec3 W = Channel(w, bu, dbu, bv, dbv);
        const float f1 = A.x / W.x, f2 = B.x / W.x;
        const float err = std::fmax(std::fabs(f1), std::fabs(f2));
        if (err < eps) return true;
        if (!(err <= prev) || it == kPatchIterations) return false;
        prev = err;
        const float j11 = (A.y - f1 * W.y) / W.x, j12 = (A.z - f1 * W.z) / W.x;
        const float j21 = (B.y - f2 * W.y) / W.x, j22 = (B.z - f2 * W.z) / W.x;
        const float det = j11 * j22 - j12 * j21;
        if (std::fabs(det) > 1e-7f * (std::fabs(j11 * j22) + std::fabs(j12 * j21))) {
            s -= (j22 * f1 - j12 * f2) / det;
            t -= (j11 * f2 - j21 * f1) / det;
        } else {
            s += s <= 0.5f ? 0.125f : -0.125f;
            t += t <= 0.5f ? 0.0625f : -0.0625f;
            prev = INFINITY;
        }
        if (!(s > -0.5f && s < 1.5f && t > -0.5f && t < 1.5f)) return false;
    }
}

}  // namespace patch_detail

// The kernels' Newton iteration (cl/patch.cl rc_intersect_patch_box) on control points `p` as
// the device holds them (float), restarts included. On a hit: t in (tMin, tMax), local (u, v).
inline bool IntersectPatchNewton(const glm::vec3& o, const glm::vec3& d, float tMin, float tMax,
                                 const std::array<glm::vec4, 16>& p, bool closedU, bool closedV,
                                 float& tOut, float& uOut, float& vOut) {
    using namespace patch_detail;
    glm::vec3 n1, n2;
    Planes(d, n1, n2);
    float a[16], b[16], w[16];
    float spread = 0.0f, wMin = INFINITY;
    int signs = 0;
    for (int k = 0; k < 16; ++k) {
        const glm::vec3 r = glm::vec3(p[k]) - o * p[k].w;
        a[k] = Dot(n1, r);
        b[k] = Dot(n2, r);
        w[k] = p[k].w;
        spread = std::fmax(spread, std::fabs(a[k]) + std::fabs(b[k]));
        wMin = std::fmin(wMin, p[k].w);
        signs |= (a[k] > 0.0f ? 1 : 0) | (a[k] < 0.0f ? 2 : 0) | (b[k] > 0.0f ? 4 : 0) |
                 (b[k] < 0.0f ? 8 : 0);
    }
    if ((signs & 3) != 3 || (signs & 12) != 12) return false;
    const float eps = spread / wMin * kPatchEps;
    float c[16];
    for (int k = 0; k < 16; ++k) c[k] = Dot(d, glm::vec3(p[k]) - o * p[k].w);
    bool found = false, centreConverged = false;
    float nearest = tMax;
    for (int start = 0; start < kPatchStarts && !centreConverged; ++start) {
        float s = PatchStartS(start), t = PatchStartT(start);
        if (start > 0 &&
            !(QuarterStraddles(a, s > 0.5f, t > 0.5f) && QuarterStraddles(b, s > 0.5f, t > 0.5f))) {
            continue;
        }
        float bu[4], dbu[4], bv[4], dbv[4];
        if (!NewtonSearch(a, b, w, eps, s, t, bu, dbu, bv, dbv)) continue;
        centreConverged = start == 0;
        if (!InPatchBox(s, t, closedU, closedV)) continue;
        const float th = Channel(c, bu, dbu, bv, dbv).x / Channel(w, bu, dbu, bv, dbv).x;
        if (!(th > tMin && th < nearest)) continue;
        nearest = th;
        tOut = th;
        uOut = s;
        vOut = t;
        found = true;
    }
    return found;
}

// The box's control points as the device holds them.
inline std::array<glm::vec4, 16> DevicePoints(const scene::PatchBox& box) {
    std::array<glm::vec4, 16> p;
    for (int k = 0; k < 16; ++k) p[size_t(k)] = glm::vec4(box.p[size_t(k)]);
    return p;
}

namespace patch_detail {

// The reference's recursion over the part [s0, s1] x [t0, t1] of the box with control points
// `part`; `whole` is the box's own net, on which the roots are polished.
struct ReferenceSearch {
    const std::array<glm::dvec4, 16>& whole;
    glm::dvec3 o, d, n1, n2;
    double tMin, tMax, dd;
    bool closedU, closedV;
    double bestT = INFINITY, bestU = 0, bestV = 0;

    void Project(const std::array<glm::dvec4, 16>& p, double* a, double* b, double* w,
                 double* c) const {
        for (int k = 0; k < 16; ++k) {
            const glm::dvec3 r = glm::dvec3(p[size_t(k)]) - o * p[size_t(k)].w;
            a[k] = Dot(n1, r);
            b[k] = Dot(n2, r);
            c[k] = Dot(d, r) / dd;
            w[k] = p[size_t(k)].w;
        }
    }

    void Search(const std::array<glm::dvec4, 16>& part, double s0, double s1, double t0, double t1,
                int depth) {
        double a[16], b[16], w[16], c[16];
        Project(part, a, b, w, c);
        double lo = INFINITY, hi = -INFINITY;
        int signs = 0;
        for (int k = 0; k < 16; ++k) {
            signs |= (a[k] >= 0 ? 1 : 0) | (a[k] <= 0 ? 2 : 0) | (b[k] >= 0 ? 4 : 0) |
                     (b[k] <= 0 ? 8 : 0);
            lo = std::min(lo, c[k] / w[k]);
            hi = std::max(hi, c[k] / w[k]);
        }
        if ((signs & 3) != 3 || (signs & 12) != 12 || hi <= tMin || lo >= std::min(tMax, bestT)) {
            return;
        }
        if (depth == 12) {
            Polish(0.5 * (s0 + s1), 0.5 * (t0 + t1));
            return;
        }
        const bool alongU = depth % 2 == 0;
        const auto halves = scene::HalvePatch(part, alongU);
        const double sm = 0.5 * (s0 + s1), tm = 0.5 * (t0 + t1);
        if (alongU) {
            Search(halves[0], s0, sm, t0, t1, depth + 1);
            Search(halves[1], sm, s1, t0, t1, depth + 1);
        } else {
            Search(halves[0], s0, s1, t0, tm, depth + 1);
            Search(halves[1], s0, s1, tm, t1, depth + 1);
        }
    }

    // Newton's method until |F| stops falling (double's limit, far below the float kernels'
    // tolerance, so a secondary ray's origin offset of a few ulps in double is resolved); a root
    // counts when |F| got below 1e-10 of the control points' spread around the ray.
    void Polish(double s, double t) {
        double a[16], b[16], w[16], c[16];
        Project(whole, a, b, w, c);
        double spread = 0.0;
        for (int k = 0; k < 16; ++k) {
            spread = std::max(spread, (std::fabs(a[k]) + std::fabs(b[k])) / w[k]);
        }
        double bu[4], dbu[4], bv[4], dbv[4];
        double prev = INFINITY;
        for (int it = 0; it < 40; ++it) {
            Bernstein3(s, bu, dbu);
            Bernstein3(t, bv, dbv);
            const glm::dvec3 A = Channel(a, bu, dbu, bv, dbv);
            const glm::dvec3 B = Channel(b, bu, dbu, bv, dbv);
            const glm::dvec3 W = Channel(w, bu, dbu, bv, dbv);
            const double f1 = A.x / W.x, f2 = B.x / W.x;
            const double err = std::max(std::fabs(f1), std::fabs(f2));
            const double j11 = (A.y - f1 * W.y) / W.x, j12 = (A.z - f1 * W.z) / W.x;
            const double j21 = (B.y - f2 * W.y) / W.x, j22 = (B.z - f2 * W.z) / W.x;
            const double det = j11 * j22 - j12 * j21;
            if (err == 0.0 || !(err < prev) || det == 0.0 || !std::isfinite(det)) {
                if (err <= 1e-10 * spread) Accept(s, t, c, bu, bv, W.x);
                return;
            }
            prev = err;
            s -= (j22 * f1 - j12 * f2) / det;
            t -= (j11 * f2 - j21 * f1) / det;
            if (!(s > -0.25 && s < 1.25 && t > -0.25 && t < 1.25)) return;
        }
    }

    void Accept(double s, double t, const double* c, const double* bu, const double* bv, double w) {
        if (!InPatchBox(s, t, closedU, closedV)) return;
        double th = 0.0;
        for (int i = 0; i < 4; ++i) {
            for (int j = 0; j < 4; ++j) th += bu[i] * bv[j] * c[4 * i + j];
        }
        th /= w;
        if (th > tMin && th < tMax && th < bestT) {
            bestT = th;
            bestU = s;
            bestV = t;
        }
    }
};

}  // namespace patch_detail

// The reference: subdivision, then a Newton polish in double (see the top of this file). The
// ray's direction need not be unit: t is in units of |d|.
inline bool IntersectPatchReference(const glm::dvec3& o, const glm::dvec3& d, double tMin,
                                    double tMax, const scene::PatchBox& box, double& t, double& u,
                                    double& v) {
    patch_detail::ReferenceSearch search{
        box.p, o, d, {}, {}, tMin, tMax, glm::dot(d, d), box.closedU, box.closedV};
    const glm::dvec3 unit = d / std::sqrt(search.dd);
    patch_detail::Planes(unit, search.n1, search.n2);
    search.Search(box.p, 0.0, 1.0, 0.0, 1.0, 0);
    if (!std::isfinite(search.bestT)) return false;
    t = search.bestT;
    u = search.bestU;
    v = search.bestV;
    return true;
}

// The point at local (s, t) of a box's net and the surface normal there (unnormalised; zero only
// where the patch degenerates around the point), collapsed edges handled as in cl/patch.cl.
inline glm::dvec3 PatchNormal(const std::array<glm::dvec4, 16>& p, double s, double t,
                              glm::dvec3* point = nullptr) {
    using namespace patch_detail;
    double c[4][16];
    for (int k = 0; k < 16; ++k) {
        for (int ch = 0; ch < 4; ++ch) c[ch][k] = p[size_t(k)][ch];
    }
    for (int attempt = 0; attempt < 3; ++attempt) {
        double bu[4], dbu[4], bv[4], dbv[4];
        Bernstein3(s, bu, dbu);
        Bernstein3(t, bv, dbv);
        const glm::dvec3 X = Channel(c[0], bu, dbu, bv, dbv), Y = Channel(c[1], bu, dbu, bv, dbv),
                         Z = Channel(c[2], bu, dbu, bv, dbv), W = Channel(c[3], bu, dbu, bv, dbv);
        const glm::dvec3 q = glm::dvec3(X.x, Y.x, Z.x) / W.x;
        if (attempt == 0 && point) *point = q;
        const glm::dvec3 ds = glm::dvec3(X.y, Y.y, Z.y) - q * W.y;
        const glm::dvec3 dt = glm::dvec3(X.z, Y.z, Z.z) - q * W.z;
        const glm::dvec3 n = glm::cross(ds, dt);
        if (glm::dot(n, n) > 1e-20 * glm::dot(ds, ds) * glm::dot(dt, dt)) return n;
        s += (0.5 - s) * (attempt == 0 ? 0.001 : 0.01);
        t += (0.5 - t) * (attempt == 0 ? 0.001 : 0.01);
    }
    return glm::dvec3(0.0);
}

}  // namespace rayclass::geometry
