// Rays as points of 5D ray space, after Arvo & Kirk, "Fast Ray Tracing by Ray Classification"
// (SIGGRAPH 1987): the dominant axis of the direction picks one of the 6 faces of the direction
// cube, and in that face's frame a ray is its origin (X, Y, Z) plus the slopes (u, v) of its
// direction (1, u, v), with u, v in [-1, 1].
//
// Face frame of face f = 2a + (d_a < 0): a is the dominant axis (ties go to the lower axis),
// b = (a + 1) mod 3, c = (a + 2) mod 3, s = +1 or -1 the sign of d_a. Then X = s p_a, Y = p_b,
// Z = p_c, u = d_b / |d_a|, v = d_c / |d_a|: every ray of the face runs along +X, and a ray
// parameter t advances X by t |d_a|.
//
// A ray whose origin lies outside the (padded) scene box starts at its entry point instead; a ray
// that misses the box, or has no direction, misses everything.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "rayclass/core/bounds.h"

namespace rayclass::classify {

constexpr int kFaceCount = 6;
constexpr int kDims = 5;  // X, Y, Z, u, v in that order

// A ray of a generation, as the host hands it in. Hits count for tMin < t < tMax; t is in units
// of |direction|. 32 bytes, the layout of RcRay.
struct Ray {
    glm::vec3 origin{0.0f};
    float tMin = 0.0f;
    glm::vec3 direction{0.0f, 0.0f, 1.0f};
    float tMax = 3.402823466e38f;
};

// Rays read in place from records that begin with a Ray's fields (RcRay, a mapped device buffer
// of them): `stride` bytes from one ray to the next, a multiple of 4.
class RayView {
  public:
    RayView() = default;
    // Arrays of Rays convert implicitly: they are views of stride sizeof(Ray).
    RayView(std::span<const Ray> rays)
        : data_(reinterpret_cast<const std::byte*>(rays.data())), size_(rays.size()) {}
    RayView(const std::vector<Ray>& rays) : RayView(std::span<const Ray>(rays)) {}
    RayView(const void* data, size_t size, size_t stride)
        : data_(static_cast<const std::byte*>(data)), size_(size), stride_(stride) {}
    size_t size() const { return size_; }
    size_t Stride() const { return stride_; }
    const float* Floats(size_t i) const {
        return reinterpret_cast<const float*>(data_ + i * stride_);
    }
    Ray operator[](size_t i) const {
        Ray r;
        std::memcpy(static_cast<void*>(&r), data_ + i * stride_, sizeof(Ray));
        return r;
    }
    RayView Sub(size_t begin, size_t count) const {
        return RayView(data_ + begin * stride_, count, stride_);
    }

  private:
    const std::byte* data_ = nullptr;
    size_t size_ = 0;
    size_t stride_ = sizeof(Ray);
};

// Points where many segments of a generation end: point lights, which shadow rays run to. An
// any-hit query answers a segment the same whichever way it runs, so the classification takes
// a segment that ends at one of them from that end (Oriented): the rays of a light then share
// one origin, which partitions never move, and their beams are cones from the light instead of
// boxes of origins swept towards it. Kernels trace the segment as given.
struct CommonEnds {
    static constexpr int kMax = 8;
    int n = 0;
    std::array<glm::vec3, kMax> point{};
    // A segment whose end o + tMax d lies within this of a point, in every coordinate, ends
    // there. It is a quarter of the classification's padding: taking the segment from the point
    // moves it by no more than that, and the padding keeps the rest for the beam test.
    float tolerance = 0.0f;
    // Whether every live segment of the sample FindCommonEnds read ended at one of the points:
    // then a generation is likely to hold no other (the light-cell strategy tries it).
    bool coverSample = false;

    // The point `ray` ends at, or -1.
    int Match(const Ray& ray) const;
    // `ray` as the classification takes it: from the point it ends at (origin there, tMin 0,
    // direction and segment reversed), else unchanged. The second form takes Match's answer.
    Ray Oriented(const Ray& ray) const { return Oriented(ray, Match(ray)); }
    Ray Oriented(const Ray& ray, int match) const;
};

// The common ends of `rays`, found on an even sample of up to 256 of them: the ends shared by
// at least 1/32 of the sample's segments (and two), lying in `box` (where an origin must be to
// be mapped directly). Deterministic: it depends on the rays alone.
CommonEnds FindCommonEnds(RayView rays, const Bounds3f& box, float tolerance);

// An axis-aligned interval in the 5 coordinates of one face's frame.
struct Box5 {
    std::array<float, kDims> lo;
    std::array<float, kDims> hi;

    bool Contains(const std::array<float, kDims>& p) const {
        for (int k = 0; k < kDims; ++k) {
            if (!(p[k] >= lo[k] && p[k] <= hi[k])) return false;
        }
        return true;
    }
    bool Contains(const Box5& b) const {
        for (int k = 0; k < kDims; ++k) {
            if (b.lo[k] < lo[k] || b.hi[k] > hi[k]) return false;
        }
        return true;
    }
};

// A ray mapped into 5D. `reach` is how far along X (in the face frame) the ray may travel from
// `p` before it leaves the scene box or passes tMax: the classification cuts beams there.
struct Ray5 {
    std::array<float, kDims> p;
    float reach = 0.0f;
    int face = 0;
};

inline int DominantAxis(const glm::vec3& d) {
    const glm::vec3 a = glm::abs(d);
    if (a.x >= a.y && a.x >= a.z) return 0;
    return a.y >= a.z ? 1 : 2;
}

inline int FaceOf(const glm::vec3& d) {
    const int a = DominantAxis(d);
    return 2 * a + (d[a] < 0.0f ? 1 : 0);
}

inline int FaceAxis(int face) { return face >> 1; }
inline float FaceSign(int face) { return (face & 1) ? -1.0f : 1.0f; }

// Coordinate of world point `p` along face `face`'s main axis (the frame's X).
inline float FaceX(int face, const glm::vec3& p) { return FaceSign(face) * p[FaceAxis(face)]; }

// `box` in the frame of `face`: X, Y, Z intervals (u and v span [-1, 1]). Inline: the hierarchy's
// set-up maps every primitive's box into every face.
inline Box5 BoxInFace(int face, const Bounds3f& box) {
    const int a = FaceAxis(face);
    const int b = (a + 1) % 3;
    const int c = (a + 2) % 3;
    Box5 r;
    if (face & 1) {
        r.lo[0] = -box.hi[a];
        r.hi[0] = -box.lo[a];
    } else {
        r.lo[0] = box.lo[a];
        r.hi[0] = box.hi[a];
    }
    r.lo[1] = box.lo[b];
    r.hi[1] = box.hi[b];
    r.lo[2] = box.lo[c];
    r.hi[2] = box.hi[c];
    r.lo[3] = r.lo[4] = -1.0f;
    r.hi[3] = r.hi[4] = 1.0f;
    return r;
}

// Maps a ray whose start o + tMin d lies outside `sceneBox`: see ToRay5.
bool ToRay5Clipped(const Ray& ray, const Bounds3f& sceneBox, Ray5& out);

// Maps `ray` into 5D, clipped to `sceneBox`. Returns false when the ray cannot hit anything
// inside the box (it misses it, its segment is empty, or its direction is zero or not finite).
// Inline: the classifier converts every ray of a generation with it, and most start inside.
inline bool ToRay5(const Ray& ray, const Bounds3f& sceneBox, Ray5& out) {
    const glm::vec3& d = ray.direction;
    const int a = DominantAxis(d);
    const float da = d[a] < 0.0f ? -d[a] : d[a];
    const glm::vec3 start = ray.tMin == 0.0f ? ray.origin : ray.origin + ray.tMin * d;
    const bool inside = start.x >= sceneBox.lo.x && start.x <= sceneBox.hi.x &&
                        start.y >= sceneBox.lo.y && start.y <= sceneBox.hi.y &&
                        start.z >= sceneBox.lo.z && start.z <= sceneBox.hi.z;
    // The sum is not finite when a component is NaN or infinite; the slow path sorts those out.
    if (!inside || !(da > 0.0f) || !std::isfinite(d.x + d.y + d.z) || !(ray.tMin < ray.tMax)) {
        return ToRay5Clipped(ray, sceneBox, out);
    }
    const int face = 2 * a + (d[a] < 0.0f ? 1 : 0);
    const int b = a == 2 ? 0 : a + 1;
    const int c = a == 0 ? 2 : a - 1;
    const float inv = 1.0f / da;
    out.face = face;
    out.p[0] = (face & 1) ? -start[a] : start[a];
    out.p[1] = start[b];
    out.p[2] = start[c];
    out.p[3] = d[b] * inv;
    out.p[4] = d[c] * inv;
    // Beyond the box there is nothing to hit, so tMax alone bounds the reach well enough here.
    const float reach = (ray.tMax - ray.tMin) * da;
    out.reach = reach < 3.402823466e38f ? reach : 3.402823466e38f;
    return true;
}

}  // namespace rayclass::classify
