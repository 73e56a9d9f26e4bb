#include "shaders.h"

namespace rayclass::raster::shaders {

namespace {

// Uniforms and primitive buffers every stage sees. Buffers hold the RcTriangle / RcSphere /
// RcQuadric arrays of cl/shared/rc_types.h as they are (48, 32 and 96 bytes: 3, 2 and 6 vec4s),
// or the patch boxes (patch_shaders.cpp).
constexpr const char* kCommon = R"GLSL(
#version 450 core
layout(std430, binding = 0) readonly buffer Primitives { vec4 prim[]; };
layout(std430, binding = 1) readonly buffer SlabOrder { uint order[]; };
uniform vec3 uEye, uForward, uRight, uUp;
uniform vec2 uTanHalfFov;
uniform uvec2 uSize;
uniform float uDepthScale;
uniform float uZNear;    // hulls reaching nearer to the eye plane cover the whole screen (triangles: see
                         // kTriangleGeometry)
uniform float uMargin;   // screen-space inflation of every hull, pixels
uniform uint uBase;      // global id of this kind's first primitive
)GLSL";

// Hull construction in the geometry shader. Screen space is pixels with row 0 at the top; window
// y equals the image row, so glReadPixels returns rows in image order.
constexpr const char* kGeometryCommon = R"GLSL(
layout(points) in;
flat in uint vLocal[];
flat out uint gLocal;
flat out float gNear;

vec3 ToView(vec3 p) {
    vec3 r = p - uEye;
    return vec3(dot(r, uRight), dot(r, uUp), dot(r, uForward));
}
vec2 TangentToPixel(vec2 s) {
    return vec2((s.x / uTanHalfFov.x + 1.0) * 0.5 * float(uSize.x),
                (1.0 - s.y / uTanHalfFov.y) * 0.5 * float(uSize.y));
}
vec2 ToPixel(vec3 v) { return TangentToPixel(v.xy / v.z); }
void EmitPixel(vec2 p) {
    gl_Position = vec4(2.0 * p.x / float(uSize.x) - 1.0, 2.0 * p.y / float(uSize.y) - 1.0, 0.5, 1.0);
    EmitVertex();
}
void EmitRect(vec2 lo, vec2 hi) {
    lo = max(lo, vec2(-1.0));
    hi = min(hi, vec2(uSize) + 1.0);
    if (lo.x >= hi.x || lo.y >= hi.y) return;
    EmitPixel(lo);
    EmitPixel(vec2(hi.x, lo.y));
    EmitPixel(vec2(lo.x, hi.y));
    EmitPixel(hi);
    EndPrimitive();
}
void EmitFullScreen() { EmitRect(vec2(-1.0), vec2(uSize) + 1.0); }
)GLSL";

constexpr const char* kTriangleGeometry = R"GLSL(
layout(triangle_strip, max_vertices = 4) out;
float Cross2(vec2 a, vec2 b) { return a.x * b.y - a.y * b.x; }
void main() {
    const uint i = vLocal[0];
    gLocal = i;
    vec3 a = ToView(prim[3 * i].xyz), b = ToView(prim[3 * i + 1].xyz), c = ToView(prim[3 * i + 2].xyz);
    float zmin = min(a.z, min(b.z, c.z)), zmax = max(a.z, max(b.z, c.z));
    if (zmax <= 0.0) return;  // every eye ray runs towards +z: nothing behind the eye is hit
    gNear = 0.9999 * max(zmin, 0.0);  // a hit's distance is at least its view depth
    vec3 n = cross(b - a, c - a);
    // Plane (nearly) through the eye: rays almost parallel to it make the float test's determinant
    // pure rounding noise, so the kernel can report "hits" anywhere along the plane's trace, far
    // outside the triangle.
    float rmax = max(length(a), max(length(b), length(c)));
    bool throughEye = abs(dot(n, a)) < 1e-3 * length(n) * rmax;
    if (zmin < uZNear) {
        // An eye ray meets view depths below uZNear only inside the frustum's tip, whose corners
        // lie reach / 2 from the eye. A plane farther off than that (a wall or floor passing
        // beside the eye) has all its hits beyond uZNear: bound the part of the triangle there.
        // A plane through the eye's trace cannot be covered by projecting vertices behind the
        // eye: it still covers the screen.
        float reach = 2.0 * uZNear * length(vec3(uTanHalfFov, 1.0));
        if (throughEye || abs(dot(n, a)) <= reach * length(n)) {
            EmitFullScreen();
            return;
        }
        vec3 v[3] = vec3[3](a, b, c);
        vec2 lo = vec2(1e30), hi = vec2(-1e30);
        for (int k = 0; k < 3; ++k) {
            vec3 p = v[k], q = v[(k + 1) % 3];
            if (p.z >= uZNear) {
                vec2 s = ToPixel(p);
                lo = min(lo, s);
                hi = max(hi, s);
            }
            if ((p.z >= uZNear) != (q.z >= uZNear)) {
                vec3 x = mix(p, q, (uZNear - p.z) / (q.z - p.z));
                vec2 s = TangentToPixel(x.xy / uZNear);
                lo = min(lo, s);
                hi = max(hi, s);
            }
        }
        if (hi.x < lo.x) return;  // wholly nearer than uZNear, outside the frustum's tip
        EmitRect(lo - uMargin, hi + uMargin);
        return;
    }
    vec2 A = ToPixel(a), B = ToPixel(b), C = ToPixel(c);
    // Through the eye: cover the whole trace line across the screen, as thick as the triangle's
    // projection plus the margin.
    if (throughEye && length(n.xy) > 1e-6 * length(n)) {
        vec2 m = normalize(vec2(n.x, -n.y));  // the trace's normal in pixels (rows run down)
        vec2 along = vec2(-m.y, m.x);
        float reach = length(vec2(uSize)) + length(A - 0.5 * vec2(uSize));
        float lo = min(0.0, min(dot(B - A, m), dot(C - A, m))) - uMargin;
        float hi = max(0.0, max(dot(B - A, m), dot(C - A, m))) + uMargin;
        EmitPixel(A - reach * along + lo * m);
        EmitPixel(A + reach * along + lo * m);
        EmitPixel(A - reach * along + hi * m);
        EmitPixel(A + reach * along + hi * m);
        EndPrimitive();
        return;
    }
    vec2 lo = min(A, min(B, C)) - uMargin, hi = max(A, max(B, C)) + uMargin;
    if (hi.x < 0.0 || hi.y < 0.0 || lo.x > float(uSize.x) || lo.y > float(uSize.y)) return;
    float area2 = Cross2(B - A, C - A);
    if (area2 < 0.0) {
        vec2 s = B;
        B = C;
        C = s;
        area2 = -area2;
    }
    vec2 box = hi - lo;
    if (area2 > 1e-3) {
        // Edges moved out by uMargin; vertex = v + m (n1 + n2) / (1 + n1.n2).
        vec2 e0 = B - A, e1 = C - B, e2 = A - C;
        vec2 n0 = normalize(vec2(e0.y, -e0.x)), n1 = normalize(vec2(e1.y, -e1.x)),
             n2 = normalize(vec2(e2.y, -e2.x));
        float dA = 1.0 + dot(n2, n0), dB = 1.0 + dot(n0, n1), dC = 1.0 + dot(n1, n2);
        if (min(dA, min(dB, dC)) > 1e-4) {
            vec2 A2 = A + uMargin * (n2 + n0) / dA, B2 = B + uMargin * (n0 + n1) / dB,
                 C2 = C + uMargin * (n1 + n2) / dC;
            if (0.5 * Cross2(B2 - A2, C2 - A2) < box.x * box.y) {
                EmitPixel(A2);
                EmitPixel(B2);
                EmitPixel(C2);
                EndPrimitive();
                return;
            }
        }
    }
    EmitRect(lo, hi);  // thin, edge-on or tiny: the inflated bounding rectangle
}
)GLSL";

// The bounding sphere and box of primitive i, world space.
constexpr const char* kSphereBounds = R"GLSL(
void Bounds(uint i, out vec3 c, out float r, out vec3 lo, out vec3 hi) {
    vec4 cr = prim[2 * i];
    c = cr.xyz;
    r = cr.w;
    lo = c - r;
    hi = c + r;
}
)GLSL";

constexpr const char* kQuadricBounds = R"GLSL(
void Bounds(uint i, out vec3 c, out float r, out vec3 lo, out vec3 hi) {
    lo = prim[6 * i + 3].xyz;
    hi = prim[6 * i + 4].xyz;
    c = 0.5 * (lo + hi);
    r = 0.5 * length(hi - lo) * 1.000001;
}
)GLSL";

// Bounding sphere as a screen-aligned square centred on the projected centre: what a GL point of
// computed size covers (GL points are square). Emitted by the geometry shader because llvmpipe
// caps point sizes.
constexpr const char* kSphereHull = R"GLSL(
layout(triangle_strip, max_vertices = 4) out;
vec2 TangentRange(float cx, float cz, float r) {
    // Tangents from the eye to the disc (cx, cz, r) in the x-z (or y-z) plane.
    float rho = length(vec2(cx, cz));
    float phi = atan(cx, cz), beta = asin(min(r / rho, 1.0));
    return vec2(tan(phi - beta), tan(phi + beta));
}
void main() {
    const uint i = vLocal[0];
    gLocal = i;
    vec3 c, lo, hi;
    float r;
    Bounds(i, c, r, lo, hi);
    vec3 v = ToView(c);
    if (v.z + r <= 0.0) return;
    gNear = 0.9999 * max(v.z - r, 0.0);
    if (v.z - r < uZNear) {
        EmitFullScreen();
        return;
    }
    vec2 xs = TangentRange(v.x, v.z, r), ys = TangentRange(v.y, v.z, r);
    vec2 p0 = TangentToPixel(vec2(xs.x, ys.y)), p1 = TangentToPixel(vec2(xs.y, ys.x));
    vec2 m = ToPixel(v);
    vec2 ext = max(abs(p0 - m), abs(p1 - m));
    float half_ = max(ext.x, ext.y) + uMargin;
    EmitRect(m - half_, m + half_);
}
)GLSL";

// Screen-aligned rectangle over the box's angular extents.
constexpr const char* kBillboardHull = R"GLSL(
layout(triangle_strip, max_vertices = 4) out;
void main() {
    const uint i = vLocal[0];
    gLocal = i;
    vec3 c, lo, hi;
    float r;
    Bounds(i, c, r, lo, hi);
    vec2 plo = vec2(1e30), phi = vec2(-1e30);
    float zmin = 1e30, zmax = -1e30;
    for (int k = 0; k < 8; ++k) {
        vec3 v = ToView(vec3((k & 1) != 0 ? hi.x : lo.x, (k & 2) != 0 ? hi.y : lo.y,
                             (k & 4) != 0 ? hi.z : lo.z));
        zmin = min(zmin, v.z);
        zmax = max(zmax, v.z);
        if (v.z > 0.0) {
            vec2 p = ToPixel(v);
            plo = min(plo, p);
            phi = max(phi, p);
        }
    }
    if (zmax <= 0.0) return;
    gNear = 0.9999 * max(zmin, 0.0);
    if (zmin < uZNear) {
        EmitFullScreen();
        return;
    }
    EmitRect(plo - uMargin, phi + uMargin);
}
)GLSL";

// Front faces of the bounding box grown by the footprint of uMargin pixels at its farthest
// corner, so its projection covers every pixel within uMargin of the box's projection.
constexpr const char* kBoxHull = R"GLSL(
layout(triangle_strip, max_vertices = 12) out;
vec3 lo, hi;
void Face(int axis, bool high) {
    // Corners of the face, ordered for a strip.
    int u = (axis + 1) % 3, w = (axis + 2) % 3;
    vec3 p = lo;
    p[axis] = high ? hi[axis] : lo[axis];
    for (int k = 0; k < 4; ++k) {
        vec3 q = p;
        q[u] = (k & 1) != 0 ? hi[u] : lo[u];
        q[w] = (k & 2) != 0 ? hi[w] : lo[w];
        EmitPixel(ToPixel(ToView(q)));
    }
    EndPrimitive();
}
void main() {
    const uint i = vLocal[0];
    gLocal = i;
    vec3 c;
    float r;
    Bounds(i, c, r, lo, hi);
    float far_ = 0.0;
    for (int k = 0; k < 8; ++k) {
        vec3 q = vec3((k & 1) != 0 ? hi.x : lo.x, (k & 2) != 0 ? hi.y : lo.y,
                      (k & 4) != 0 ? hi.z : lo.z);
        far_ = max(far_, length(q - uEye));
    }
    float grow = 1.01 * far_ * uMargin * 2.0 * uTanHalfFov.y / float(uSize.y);
    lo -= grow;
    hi += grow;
    float zmin = 1e30, zmax = -1e30;
    for (int k = 0; k < 8; ++k) {
        float z = ToView(vec3((k & 1) != 0 ? hi.x : lo.x, (k & 2) != 0 ? hi.y : lo.y,
                              (k & 4) != 0 ? hi.z : lo.z)).z;
        zmin = min(zmin, z);
        zmax = max(zmax, z);
    }
    if (zmax <= 0.0) return;
    gNear = 0.9999 * max(zmin, 0.0);
    if (zmin < uZNear) {
        EmitFullScreen();
        return;
    }
    // Back-face culling: a face is drawn when the eye lies outside its plane.
    for (int a = 0; a < 3; ++a) {
        if (uEye[a] < lo[a]) Face(a, false);
        else if (uEye[a] > hi[a]) Face(a, true);
    }
}
)GLSL";

// Exact ray-primitive tests, the float formulas of cl/intersect.cl operation for operation.
// `precise` forbids contraction into fused multiply-adds and reassociation, as FP_CONTRACT OFF does
// for the kernels.
constexpr const char* kFragmentCommon = R"GLSL(
flat in uint gLocal;
flat in float gNear;
layout(location = 0) out uint oId;
layout(location = 1) out float oDist;
layout(location = 2) out vec2 oUV;
#ifdef RC_COUNT
layout(binding = 0, offset = 0) uniform atomic_uint uFragments;
layout(binding = 0, offset = 4) uniform atomic_uint uTested;
layout(binding = 0, offset = 8) uniform atomic_uint uHits;
#endif
#ifdef RC_SLABS
uniform sampler2D uPrevDepth;
#endif

float Dot(vec3 a, vec3 b) {
    precise float r = a.x * b.x + a.y * b.y + a.z * b.z;
    return r;
}
vec3 Cross(vec3 a, vec3 b) {
    precise vec3 r = vec3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
    return r;
}
float CopySign(float x, float s) { return (floatBitsToUint(s) & 0x80000000u) != 0u ? -abs(x) : abs(x); }

// The eye ray of pixel (x, y), row 0 at the top: RcCamera's formula, as cl/camera.cl computes it.
vec3 EyeDirection(uint x, uint y) {
    precise float sx = (2.0 * (float(x) + 0.5) / float(uSize.x) - 1.0) * uTanHalfFov.x;
    precise float sy = (1.0 - 2.0 * (float(y) + 0.5) / float(uSize.y)) * uTanHalfFov.y;
    precise vec3 d = uForward + sx * uRight + sy * uUp;
    precise float l2 = Dot(d, d);
    precise vec3 n = d * (1.0 / sqrt(l2));
    return n;
}
)GLSL";

constexpr const char* kTriangleTest = R"GLSL(
bool Intersect(uint i, vec3 o, vec3 d, out float t, out float u, out float v) {
    u = 0.0;
    v = 0.0;
    t = 0.0;
    vec3 p0 = prim[3 * i].xyz, p1 = prim[3 * i + 1].xyz, p2 = prim[3 * i + 2].xyz;
    precise vec3 e1 = p1 - p0;
    precise vec3 e2 = p2 - p0;
    precise vec3 pv = Cross(d, e2);
    precise float det = Dot(e1, pv);
    if (det == 0.0) return false;
    precise float invDet = 1.0 / det;
    precise vec3 tv = o - p0;
    precise float uu = Dot(tv, pv) * invDet;
    u = uu;
    if (uu < 0.0 || uu > 1.0) return false;
    precise vec3 qv = Cross(tv, e1);
    precise float vv = Dot(d, qv) * invDet;
    v = vv;
    precise float uv = uu + vv;
    if (vv < 0.0 || uv > 1.0) return false;
    precise float tt = Dot(e2, qv) * invDet;
    t = tt;
    return tt > 0.0;
}
)GLSL";

constexpr const char* kSphereTest = R"GLSL(
bool Intersect(uint i, vec3 o, vec3 d, out float t, out float u, out float v) {
    u = 0.0;
    v = 0.0;
    t = 0.0;
    vec4 cr = prim[2 * i];
    precise vec3 f = o - cr.xyz;
    float r = cr.w;
    precise float a = Dot(d, d);
    precise float b = -Dot(f, d);
    precise vec3 l = f + (b / a) * d;
    precise float rr = r * r;
    precise float disc = a * (rr - Dot(l, l));
    if (disc < 0.0) return false;
    precise float c = Dot(f, f) - rr;
    precise float q = b + CopySign(sqrt(disc), b);
    precise float t0 = q == 0.0 ? 0.0 : c / q;
    precise float t1 = q / a;
    if (t0 > t1) {
        float s = t0;
        t0 = t1;
        t1 = s;
    }
    if (t0 > 0.0) {
        t = t0;
        return true;
    }
    if (t1 > 0.0) {
        t = t1;
        return true;
    }
    return false;
}
)GLSL";

constexpr const char* kQuadricTest = R"GLSL(
float QuadricValue(vec4 c0, vec4 c1, vec4 c2, vec3 p) {
    precise float r = c0.x * p.x * p.x + c0.y * p.y * p.y + c0.z * p.z * p.z + c0.w * p.x * p.y +
                      c1.x * p.x * p.z + c1.y * p.y * p.z + c1.z * p.x + c1.w * p.y + c2.x * p.z + c2.y;
    return r;
}
bool Intersect(uint i, vec3 o, vec3 d, out float t, out float u, out float v) {
    u = 0.0;
    v = 0.0;
    t = 0.0;
    vec4 c0 = prim[6 * i], c1 = prim[6 * i + 1], c2 = prim[6 * i + 2];
    vec3 lo = prim[6 * i + 3].xyz, hi = prim[6 * i + 4].xyz;
    precise float a = c0.x * d.x * d.x + c0.y * d.y * d.y + c0.z * d.z * d.z + c0.w * d.x * d.y +
                      c1.x * d.x * d.z + c1.y * d.y * d.z;
    precise float b = 2.0 * (c0.x * o.x * d.x + c0.y * o.y * d.y + c0.z * o.z * d.z) +
                      c0.w * (o.x * d.y + o.y * d.x) + c1.x * (o.x * d.z + o.z * d.x) +
                      c1.y * (o.y * d.z + o.z * d.y) + c1.z * d.x + c1.w * d.y + c2.x * d.z;
    precise float c = QuadricValue(c0, c1, c2, o);
    float roots[2];
    int nRoots = 0;
    if (a == 0.0) {
        if (b == 0.0) return false;
        precise float r = -c / b;
        roots[nRoots++] = r;
    } else {
        precise float disc = b * b - 4.0 * a * c;
        if (disc < 0.0) return false;
        precise float qq = -0.5 * (b + CopySign(sqrt(disc), b));
        precise float r0 = qq / a;
        precise float r1 = qq == 0.0 ? r0 : c / qq;
        if (r0 > r1) {
            float s = r0;
            r0 = r1;
            r1 = s;
        }
        roots[nRoots++] = r0;
        roots[nRoots++] = r1;
    }
    for (int k = 0; k < nRoots; ++k) {
        float ti = roots[k];
        if (!(ti > 0.0)) continue;
        precise vec3 p = o + ti * d;
        if (p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z &&
            p.z <= hi.z) {
            t = ti;
            return true;
        }
    }
    return false;
}
)GLSL";

constexpr const char* kFragmentMain = R"GLSL(
void main() {
#ifdef RC_COUNT
    atomicCounterIncrement(uFragments);
#endif
    uint x = uint(gl_FragCoord.x), y = uint(gl_FragCoord.y);
#ifdef RC_SLABS
    // The hull cannot come nearer than gNear: behind the hit of an earlier slab, skip the test.
    if (gNear * uDepthScale >= texelFetch(uPrevDepth, ivec2(x, y), 0).r) discard;
#endif
#ifdef RC_COUNT
    atomicCounterIncrement(uTested);
#endif
    vec3 d = EyeDirection(x, y);
    float t, u, v;
    if (!Intersect(gLocal, uEye, d, t, u, v)) discard;
#ifdef RC_COUNT
    atomicCounterIncrement(uHits);
#endif
    gl_FragDepth = t * uDepthScale;
    oId = uBase + gLocal;
    oDist = t;
    oUV = vec2(u, v);
}
)GLSL";

}  // namespace

std::string Vertex(int /*kind*/, bool slabs) {
    std::string s = kCommon;
    s += "flat out uint vLocal;\n";
    s += slabs ? "void main() { vLocal = order[gl_VertexID]; }\n"
               : "void main() { vLocal = uint(gl_VertexID); }\n";
    return s;
}

std::string Geometry(int kind, int hull) {
    std::string s = std::string(kCommon) + kGeometryCommon;
    if (kind == 0) return s + kTriangleGeometry;
    s += kind == 1 ? kSphereBounds : kind == 2 ? kQuadricBounds : PatchBounds();
    s += hull == 0 ? kSphereHull : hull == 1 ? kBoxHull : kBillboardHull;
    return s;
}

std::string Fragment(int kind, bool count, bool slabs) {
    std::string s = kCommon;
    // #defines must follow #version, which kCommon starts with.
    if (count) s += "#define RC_COUNT 1\n";
    if (slabs) s += "#define RC_SLABS 1\n";
    s += kFragmentCommon;
    s += kind == 0   ? kTriangleTest
         : kind == 1 ? kSphereTest
         : kind == 2 ? kQuadricTest
                     : PatchTest();
    s += kFragmentMain;
    return s;
}

}  // namespace rayclass::raster::shaders
