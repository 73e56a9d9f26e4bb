// GLSL of the raster pass's patch boxes: their box as the hull, and the Newton iteration of
// cl/patch.cl (rc_intersect_patch_box) operation for operation in the fragment shader, so a pixel
// gets the kernel's hit bit for bit. `precise` forbids fused multiply-adds and reassociation, as
// FP_CONTRACT OFF does for the kernels.
#include "shaders.h"

namespace rayclass::raster::shaders {

// A patch box is kPatchBoxVec4s vec4s (PatchBoxArray): (boxMin, closedU), (boxMax, closedV),
// then the 16 homogeneous control points, point (i, j) at 2 + 4 i + j.
const char* PatchBounds() {
    return R"GLSL(
void Bounds(uint i, out vec3 c, out float r, out vec3 lo, out vec3 hi) {
    lo = prim[18u * i].xyz;
    hi = prim[18u * i + 1u].xyz;
    c = 0.5 * (lo + hi);
    r = 0.5 * length(hi - lo) * 1.000001;
}
)GLSL";
}

const char* PatchTest() {
    return R"GLSL(
const int kPatchIterations = 12;
const float kPatchEps = 1.0 / 262144.0;

float Inf() { return uintBitsToFloat(0x7f800000u); }
// OpenCL's fmax and fmin: a NaN operand yields the other one.
float FMax(float a, float b) { return isnan(a) ? b : isnan(b) ? a : max(a, b); }
float FMin(float a, float b) { return isnan(a) ? b : isnan(b) ? a : min(a, b); }

void Bernstein3(float s, out float b[4], out float db[4]) {
    precise float r = 1.0 - s;
    precise float b0 = r * r * r, b1 = 3.0 * s * r * r, b2 = 3.0 * s * s * r, b3 = s * s * s;
    precise float d0 = -3.0 * r * r, d1 = 3.0 * r * (r - 2.0 * s), d2 = 3.0 * s * (2.0 * r - s),
                  d3 = 3.0 * s * s;
    b = float[4](b0, b1, b2, b3);
    db = float[4](d0, d1, d2, d3);
}

vec3 Channel(float c[16], float bu[4], float dbu[4], float bv[4], float dbv[4]) {
    precise float x = 0.0, xs = 0.0, xt = 0.0;
    for (int i = 0; i < 4; ++i) {
        precise float row = bv[0] * c[4 * i] + bv[1] * c[4 * i + 1] + bv[2] * c[4 * i + 2] +
                            bv[3] * c[4 * i + 3];
        precise float rowD = dbv[0] * c[4 * i] + dbv[1] * c[4 * i + 1] + dbv[2] * c[4 * i + 2] +
                             dbv[3] * c[4 * i + 3];
        x += bu[i] * row;
        xs += dbu[i] * row;
        xt += bu[i] * rowD;
    }
    precise vec3 r = vec3(x, xs, xt);
    return r;
}

// cl/patch.cl rc_patch_half_curve: the half towards c3 when `upper`, else towards c0.
void HalfCurve(float c0, float c1, float c2, float c3, bool upper, out float q[4]) {
    precise float a = 0.5 * (c0 + c1), b = 0.5 * (c1 + c2), d = 0.5 * (c2 + c3);
    precise float ab = 0.5 * (a + b), bd = 0.5 * (b + d), m = 0.5 * (ab + bd);
    if (upper) {
        q = float[4](m, bd, d, c3);
    } else {
        q = float[4](c0, a, ab, m);
    }
}

// cl/patch.cl rc_patch_quarter_straddles.
bool QuarterStraddles(float x[16], bool qu, bool qv) {
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
        for (int j = 0; j < 4; ++j) signs |= (q[j] >= 0.0 ? 1 : 0) | (q[j] <= 0.0 ? 2 : 0);
    }
    return signs == 3;
}

// cl/patch.cl rc_patch_newton_search: whether the search from (s, q) converged; (s, q) and the
// weights are those of the last point evaluated.
bool Search(float a[16], float b[16], float w[16], float eps, inout float s, inout float q,
            out float bu[4], out float dbu[4], out float bv[4], out float dbv[4]) {
    float prev = Inf();
    for (int it = 0; it <= kPatchIterations; ++it) {
        Bernstein3(s, bu, dbu);
        Bernstein3(q, bv, dbv);
        precise vec3 A = Channel(a, bu, dbu, bv, dbv);
        precise vec3 B = Channel(b, bu, dbu, bv, dbv);
        precise vec3 W = Channel(w, bu, dbu, bv, dbv);
        precise float f1 = A.x / W.x, f2 = B.x / W.x;
        float err = FMax(abs(f1), abs(f2));
        if (err < eps) return true;
        if (!(err <= prev) || it == kPatchIterations) return false;
        prev = err;
        precise float j11 = (A.y - f1 * W.y) / W.x, j12 = (A.z - f1 * W.z) / W.x;
        precise float j21 = (B.y - f2 * W.y) / W.x, j22 = (B.z - f2 * W.z) / W.x;
        precise float det = j11 * j22 - j12 * j21;
        precise float scale = 1e-7 * (abs(j11 * j22) + abs(j12 * j21));
        precise float sNext, qNext;
        if (abs(det) > scale) {
            sNext = s - (j22 * f1 - j12 * f2) / det;
            qNext = q - (j11 * f2 - j21 * f1) / det;
        } else {
            sNext = s + (s <= 0.5 ? 0.125 : -0.125);
            qNext = q + (q <= 0.5 ? 0.0625 : -0.0625);
            prev = Inf();
        }
        s = sNext;
        q = qNext;
        if (!(s > -0.5 && s < 1.5 && q > -0.5 && q < 1.5)) return false;
    }
    return false;
}

bool Intersect(uint i, vec3 o, vec3 d, out float t, out float u, out float v) {
    u = 0.0;
    v = 0.0;
    t = 0.0;
    uint base = 18u * i;
    precise vec3 n = abs(d.x) > abs(d.y) && abs(d.x) > abs(d.z) ? vec3(d.y, -d.x, 0.0)
                                                                : vec3(0.0, d.z, -d.y);
    precise float len = sqrt(Dot(n, n));
    precise vec3 n1 = n / len;
    precise vec3 n2 = Cross(d, n1);
    precise float a[16], b[16], w[16], c[16];
    precise float spread = 0.0;
    float wMin = Inf();
    int signs = 0;
    for (int k = 0; k < 16; ++k) {
        vec4 p = prim[base + 2u + uint(k)];
        precise vec3 r = p.xyz - o * p.w;
        a[k] = Dot(n1, r);
        b[k] = Dot(n2, r);
        c[k] = Dot(d, r);
        w[k] = p.w;
        precise float sum = abs(a[k]) + abs(b[k]);
        spread = FMax(spread, sum);
        wMin = FMin(wMin, p.w);
        signs |= (a[k] > 0.0 ? 1 : 0) | (a[k] < 0.0 ? 2 : 0) | (b[k] > 0.0 ? 4 : 0) |
                 (b[k] < 0.0 ? 8 : 0);
    }
    // All control points on one side of a plane: the ray misses the convex hull.
    if ((signs & 3) != 3 || (signs & 12) != 12) return false;
    precise float eps = spread / wMin * kPatchEps;
    bool closedU = prim[base].w != 0.0, closedV = prim[base + 1u].w != 0.0;
    // cl/patch.cl RC_PATCH_STARTS: the box's centre, then, when that search does not converge,
    // the centres of the quarters whose hull the ray meets, the nearest of their hits counting.
    bool found = false, centreConverged = false;
    float nearest = Inf();
    for (int start = 0; start < 5 && !centreConverged; ++start) {
        float s = start == 0 ? 0.5 : (start & 1) != 0 ? 0.25 : 0.75;
        float q = start == 0 ? 0.5 : start <= 2 ? 0.25 : 0.75;
        if (start > 0 && !(QuarterStraddles(a, s > 0.5, q > 0.5) &&
                           QuarterStraddles(b, s > 0.5, q > 0.5))) {
            continue;
        }
        float bu[4], dbu[4], bv[4], dbv[4];
        if (!Search(a, b, w, eps, s, q, bu, dbu, bv, dbv)) continue;
        centreConverged = start == 0;
        if (!(s >= 0.0 && (s < 1.0 || (closedU && s == 1.0)))) continue;
        if (!(q >= 0.0 && (q < 1.0 || (closedV && q == 1.0)))) continue;
        precise vec3 C = Channel(c, bu, dbu, bv, dbv);
        precise vec3 W = Channel(w, bu, dbu, bv, dbv);
        precise float th = C.x / W.x;
        if (!(th > 0.0 && th < nearest)) continue;
        nearest = th;
        t = th;
        u = s;
        v = q;
        found = true;
    }
    return found;
}
)GLSL";
}

}  // namespace rayclass::raster::shaders
