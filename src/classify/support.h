// Helpers the classify module's files share: threads, scratch growth and a node's tight bounds.
// Private to the module.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <future>
#include <limits>
#include <vector>

#include "rayclass/classify/ray5d.h"
#include "rayclass/core/helper_threads.h"

namespace rayclass::classify {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kFloatMax = 3.402823466e38f;
constexpr int kCoords = kDims + 1;  // the 5D point and the X where the ray ends

// Runs f(t) for t in [0, n), f(0) on the calling thread, the others on helper threads where
// one is free in time (see OnHelpers): the calls must not wait for each other.
template <typename F>
void OnThreads(int n, const F& f) {
    OnHelpers(n, [&f](int t) { f(t); });
}

// Runs f(t) for t in [0, n) at once, each on a thread of its own (f(0) on the calling thread):
// for calls that wait for each other.
template <typename F>
void OnThreadsAtOnce(int n, const F& f) {
    std::vector<std::future<void>> others;
    for (int t = 1; t < n; ++t) others.push_back(std::async(std::launch::async, [&f, t] { f(t); }));
    f(0);
    for (auto& o : others) o.get();
}

// Scratch is resized without keeping its contents: growing then copies nothing, so the
// uninitialised tail of the old buffer is never read. (Reading it maps the zero page, and writing
// that memory after malloc hands it out again costs a copy-on-write fault and a TLB shootdown
// on every core.)
template <typename V>
void Regrow(V& v, size_t n) {
    if (n > v.capacity()) {
        // Geometric growth, as resize() would do: a list that grows a little at a time must not
        // be reallocated (and its pages faulted in again) every time.
        v.clear();
        v.reserve(std::max(n, 2 * v.capacity()));
    }
    v.resize(n);
}

// A node's tight bounds: X, Y, Z, u, v and the end X of its rays (index kDims).
struct Bounds6 {
    float lo[kCoords];
    float hi[kCoords];
    Box5 ToBox5() const {
        Box5 b;
        for (int k = 0; k < kDims; ++k) {
            b.lo[k] = lo[k];
            b.hi[k] = hi[k];
        }
        return b;
    }
};

// b grows to contain `other`.
inline void Merge(Bounds6& b, const Bounds6& other) {
    for (int k = 0; k < kCoords; ++k) {
        b.lo[k] = std::min(b.lo[k], other.lo[k]);
        b.hi[k] = std::max(b.hi[k], other.hi[k]);
    }
}

inline void GrowBounds(Bounds6& b, const float* p) {
    for (int k = 0; k < kCoords; ++k) {
        b.lo[k] = std::min(b.lo[k], p[k]);
        b.hi[k] = std::max(b.hi[k], p[k]);
    }
}

// The midpoint split of [lo, hi]. When lo and hi are adjacent floats the middle rounds onto lo;
// hi still splits them.
inline float Midpoint(float lo, float hi) {
    const float m = 0.5f * (lo + hi);
    return m > lo ? m : hi;
}

// Whether coordinate k varies among the rays of bounds b: only such coordinates are stored.
inline bool Varies(const Bounds6& b, int k) { return b.lo[k] < b.hi[k]; }

// The face of a ray's direction, or kFaceCount when the direction is zero or not finite (such a
// ray misses everything, whichever path ToRay5 takes). ToRay5 picks the same face for the rest.
inline int DirectionFace(const glm::vec3& d) {
    if (!std::isfinite(d.x) || !std::isfinite(d.y) || !std::isfinite(d.z)) return kFaceCount;
    const int a = DominantAxis(d);
    if (!(std::abs(d[a]) > 0.0f)) return kFaceCount;
    return 2 * a + (d[a] < 0.0f ? 1 : 0);
}

inline Bounds6 EmptyBounds() {
    Bounds6 b;
    for (int k = 0; k < kCoords; ++k) {
        b.lo[k] = kInf;
        b.hi[k] = -kInf;
    }
    return b;
}

}  // namespace rayclass::classify
