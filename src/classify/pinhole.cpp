// Eye rays of a pinhole camera classified by rectangles of the image (PinholeSubdivision).
#include "pinhole.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "filter.h"
#include "support.h"

namespace rayclass::classify {

namespace {

// A rectangle takes a face's frame once none of its corners' slopes exceeds this there.
constexpr double kMaxSlope = 1.5;
// Slope padding, relative to 1 + |slope|. The kernel's float direction (a sum of three products,
// normalised) errs by a few 1e-7 of that, and so does rounding the padded bound to float: the
// padding is 20x more. A leaf's beam is wider by far (8 pixels of a 60-degree, 1024-pixel image
// span 8e-3 in slope), so the padding lengthens no list by much.
constexpr double kSlopePad = 1e-5;
// The camera may lie this many scene-box sizes outside the box. Its coordinates then stay below
// 4 x 65534 < 2^18 of the lists' steps, where float rounding in the filter (half an ulp, 2^-6
// steps) is half the filter's margin (filter.cpp). Cornell's camera is 1.4 sizes away.
constexpr float kCameraReach = 3.0f;
// Growth of the scene box, relative to its diagonal, beyond which a ray from an outside camera
// cannot reach a primitive: float and double rays part by a few 1e-7 of their length, at most
// 5 diagonals here (kCameraReach), so 1e-5 leaves a margin of four.
constexpr double kMissMargin = 1e-5;
// A leaf on the outline of the scene box, seen from outside, is halved down to this many
// pixels before its rays are tested against the box one by one.
constexpr uint64_t kClipPixels = 64;
// A rectangle's width is split at a multiple of this many columns where it can be, so that the
// 16 rays of a fragment packet span few rows.
constexpr uint32_t kColumnAlign = 4;
// Batches of this many rays or more are cut into kBands bands of rows, which the threads take
// in turn. Each band filters a face's whole list first, but with one band a thread the threads'
// work was uneven. The bands do not depend on the thread count, and neither
// does the result.
constexpr uint32_t kBandedRaysMin = 32768;
constexpr uint32_t kBands = 8;

bool Finite(const rc_float4& v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

}  // namespace

struct PinholeSubdivision::Camera {
    glm::dvec3 position, forward, right, up;
    double tanX = 1.0, tanY = 1.0;
    uint32_t width = 1, height = 1;     // the camera window's: pixels are numbered in the window
    uint32_t originX = 0, originY = 0;  // the window's place in the image
    uint64_t first = 0, last = 0;       // the batch: pixels [first, last)
    uint32_t yFirst = 0, yLast = 0;     // the rows of its first and last pixels
    float eye[kFaceCount][3];           // the position in each face's frame, as Convert maps it
    float end[kFaceCount];              // where each face's X leaves the scene box

    double perWidth = 1.0, perHeight = 1.0;  // 2 / the image's width, 2 / its height
    // From a camera outside the scene box, rays that miss `reachable` (the box grown by
    // kMissMargin of its diagonal, which float rays cannot cross while their double twins here
    // miss) get no leaf.
    bool outside = false;
    glm::dvec3 reachableLo{0.0}, reachableHi{0.0};

    // cl/camera.cl's direction of the window's pixel (x, y) in double, before normalising
    // (reciprocals for its divisions: errors of an ulp of a double, far inside kSlopePad).
    glm::dvec3 Direction(uint32_t x, uint32_t y) const {
        const double sx = ((double(originX) + x + 0.5) * perWidth - 1.0) * tanX;
        const double sy = (1.0 - (double(originY) + y + 0.5) * perHeight) * tanY;
        return forward + sx * right + sy * up;
    }

    // The batch's pixels of row y in r: [lo, hi) (empty when hi <= lo).
    void RowSpan(const PixelRect& r, uint32_t y, uint64_t& lo, uint64_t& hi) const {
        const uint64_t row = uint64_t(y) * width;
        lo = std::max(row + r.x0, first);
        hi = std::min(row + r.x1, last);
    }

    // The batch's pixels in `r`: whole rows but for the batch's first and last.
    uint32_t Count(const PixelRect& r) const {
        const uint32_t y0 = std::max(r.y0, yFirst), y1 = std::min(r.y1, yLast + 1);
        if (y0 >= y1) return 0;
        uint64_t n = uint64_t(y1 - y0) * (r.x1 - r.x0);
        auto clip = [&](uint32_t y) {
            if (y < y0 || y >= y1) return;
            uint64_t lo, hi;
            RowSpan(r, y, lo, hi);
            n -= r.x1 - r.x0;
            if (hi > lo) n += hi - lo;
        };
        clip(yFirst);
        if (yLast != yFirst) clip(yLast);
        return uint32_t(n);
    }

    // The face of r's centre ray (ties to the lower axis, as FaceOf).
    int CentreFace(const PixelRect& r) const {
        const glm::dvec3 d = Direction(r.x0 + (r.x1 - r.x0 - 1) / 2, r.y0 + (r.y1 - r.y0 - 1) / 2);
        const glm::dvec3 a = glm::abs(d);
        const int axis = a.x >= a.y && a.x >= a.z ? 0 : (a.y >= a.z ? 1 : 2);
        return 2 * axis + (d[axis] < 0.0 ? 1 : 0);
    }

    // The slopes of pixel (x, y)'s ray in the frame of `face`; false when it does not move
    // forward there.
    bool Slopes(uint32_t x, uint32_t y, int face, double slope[2]) const {
        const int a = FaceAxis(face), ab = (a + 1) % 3, ac = (a + 2) % 3;
        const glm::dvec3 d = Direction(x, y);
        const double da = FaceSign(face) * d[a];
        if (!(da > 0.0)) return false;
        const double perDa = 1.0 / da;
        slope[0] = d[ab] * perDa;
        slope[1] = d[ac] * perDa;
        return true;
    }

    // The bounds of r's rays in the frame of `face`, with its corners' slopes in `c`. False
    // when a corner ray does not move forward there or a corner's slope exceeds kMaxSlope.
    bool Bounds(const PixelRect& r, int face, Bounds6& b, Corners& c) const {
        for (int i = 0; i < 2; ++i) {
            for (int j = 0; j < 2; ++j) {
                double* const s = c.slope[i][j];
                if (!Slopes(j ? r.x1 - 1 : r.x0, i ? r.y1 - 1 : r.y0, face, s)) return false;
                if (!(std::abs(s[0]) <= kMaxSlope && std::abs(s[1]) <= kMaxSlope)) return false;
            }
        }
        FromCorners(c, face, b);
        return true;
    }

    // The bounds of the halves `half` of `r` (Halve), whose corners' slopes are `c`, in `beam`:
    // each half shares two corners with r, so only the four along the cut are new. Within r's
    // frame their rays move forward, as r's do.
    void HalfBounds(const PixelRect& r, const Corners& c, const PixelRect half[2], int face,
                    RectBeam beam[2]) const {
        Corners& c0 = beam[0].corners;
        Corners& c1 = beam[1].corners;
        c0 = c1 = c;
        if (half[0].x1 != r.x1) {
            for (int i = 0; i < 2; ++i) {
                const uint32_t y = i ? r.y1 - 1 : r.y0;
                Slopes(half[0].x1 - 1, y, face, c0.slope[i][1]);
                Slopes(half[1].x0, y, face, c1.slope[i][0]);
            }
        } else {
            for (int j = 0; j < 2; ++j) {
                const uint32_t x = j ? r.x1 - 1 : r.x0;
                Slopes(x, half[0].y1 - 1, face, c0.slope[1][j]);
                Slopes(x, half[1].y0, face, c1.slope[0][j]);
            }
        }
        for (int h = 0; h < 2; ++h) FromCorners(beam[h].corners, face, beam[h].tight);
    }

    // The bounds of the rays between corners' slopes `c` in the frame of `face`, padded.
    void FromCorners(const Corners& c, int face, Bounds6& b) const {
        double lo[2] = {HUGE_VAL, HUGE_VAL}, hi[2] = {-HUGE_VAL, -HUGE_VAL};
        for (int i = 0; i < 2; ++i) {
            for (int j = 0; j < 2; ++j) {
                for (int k = 0; k < 2; ++k) {
                    lo[k] = std::min(lo[k], c.slope[i][j][k]);
                    hi[k] = std::max(hi[k], c.slope[i][j][k]);
                }
            }
        }
        for (int k = 0; k < 3; ++k) b.lo[k] = b.hi[k] = eye[face][k];
        for (int k = 0; k < 2; ++k) {
            b.lo[3 + k] = float(lo[k] - kSlopePad * (1.0 + std::abs(lo[k])));
            b.hi[3 + k] = float(hi[k] + kSlopePad * (1.0 + std::abs(hi[k])));
        }
        b.lo[kDims] = b.hi[kDims] = end[face];
    }

    // Whether pixel (x, y)'s ray (t >= 0) meets `reachable`: the slab test, in double.
    bool Reaches(uint32_t x, uint32_t y) const {
        const glm::dvec3 d = Direction(x, y);
        double t0 = 0.0, t1 = HUGE_VAL;
        for (int k = 0; k < 3; ++k) {
            if (d[k] == 0.0) {
                if (position[k] < reachableLo[k] || position[k] > reachableHi[k]) return false;
                continue;
            }
            double a = (reachableLo[k] - position[k]) / d[k],
                   b = (reachableHi[k] - position[k]) / d[k];
            if (a > b) std::swap(a, b);
            t0 = std::max(t0, a);
            t1 = std::min(t1, b);
        }
        return t0 <= t1;
    }

    // Whether every ray of r meets `reachable`: the directions that meet a convex set form a
    // convex cone, so its corners' rays decide.
    bool AllReach(const PixelRect& r) const {
        for (uint32_t y : {r.y0, r.y1 - 1}) {
            for (uint32_t x : {r.x0, r.x1 - 1}) {
                if (!Reaches(x, y)) return false;
            }
        }
        return true;
    }

    // The halves of r across its longer side.
    static void Halve(const PixelRect& r, PixelRect half[2]) {
        half[0] = half[1] = r;
        const uint32_t w = r.x1 - r.x0, h = r.y1 - r.y0;
        if (w >= h) {
            uint32_t mid = (r.x0 + w / 2) / kColumnAlign * kColumnAlign;
            if (mid <= r.x0) mid = r.x0 + w / 2;
            half[0].x1 = half[1].x0 = mid;
        } else {
            half[0].y1 = half[1].y0 = r.y0 + h / 2;
        }
    }
    // The camera of `camera`'s pixels [firstPixel, firstPixel + n) of its window, in the face
    // frames of scene box `box`; false when its basis is degenerate or not finite, the window or
    // the pixels run past the image, or it lies more than kCameraReach box sizes outside the box.
    bool Set(const RcCamera& camera, uint32_t firstPixel, uint32_t n, const Bounds3f& box);
};

bool PinholeSubdivision::Camera::Set(const RcCamera& camera, uint32_t firstPixel, uint32_t n,
                                     const Bounds3f& box) {
    const glm::vec3 eyeAt(camera.position.x, camera.position.y, camera.position.z);
    const glm::dvec3 f(camera.forward.x, camera.forward.y, camera.forward.z);
    const glm::dvec3 r(camera.right.x, camera.right.y, camera.right.z);
    const glm::dvec3 u(camera.up.x, camera.up.y, camera.up.z);
    // No pixel's direction is zero while forward is off the plane of right and up.
    const bool sane =
        Finite(camera.position) && Finite(camera.forward) && Finite(camera.right) &&
        Finite(camera.up) && std::isfinite(camera.tanHalfFovX) &&
        std::isfinite(camera.tanHalfFovY) && camera.width > 0 && camera.height > 0 &&
        glm::dot(f, glm::cross(r, u)) != 0.0 && camera.windowWidth > 0 && camera.windowHeight > 0 &&
        uint64_t(camera.windowX) + camera.windowWidth <= camera.width &&
        uint64_t(camera.windowY) + camera.windowHeight <= camera.height &&
        uint64_t(firstPixel) + n <= uint64_t(camera.windowWidth) * camera.windowHeight;
    // The rays are not clipped to the scene box, as Convert clips rays: the beams start at the
    // camera, which is exact for them too, and ProcessRect answers the rays that cannot reach
    // the box as misses.
    const glm::vec3 reach = box.Size() * kCameraReach;
    const bool near = glm::all(glm::greaterThanEqual(eyeAt, box.lo - reach)) &&
                      glm::all(glm::lessThanEqual(eyeAt, box.hi + reach));
    if (!sane || box.Empty() || !near) return false;
    position = glm::dvec3(eyeAt);
    forward = f;
    right = r;
    up = u;
    tanX = camera.tanHalfFovX;
    tanY = camera.tanHalfFovY;
    width = camera.windowWidth;
    height = camera.windowHeight;
    originX = camera.windowX;
    originY = camera.windowY;
    perWidth = 2.0 / double(camera.width);
    perHeight = 2.0 / double(camera.height);
    first = firstPixel;
    last = uint64_t(firstPixel) + n;
    yFirst = uint32_t(first / width);
    yLast = uint32_t((last - 1) / width);
    for (int face = 0; face < kFaceCount; ++face) {
        const int a = FaceAxis(face);
        eye[face][0] = FaceX(face, eyeAt);
        eye[face][1] = eyeAt[(a + 1) % 3];
        eye[face][2] = eyeAt[(a + 2) % 3];
        end[face] = BoxInFace(face, box).hi[0];
    }
    outside = !glm::all(glm::greaterThanEqual(eyeAt, box.lo)) ||
              !glm::all(glm::lessThanEqual(eyeAt, box.hi));
    const double grow = kMissMargin * double(box.Diagonal());
    reachableLo = glm::dvec3(box.lo) - grow;
    reachableHi = glm::dvec3(box.hi) + grow;
    return true;
}

bool PinholeSubdivision::Classify(const RcCamera& camera, uint32_t first, uint32_t n,
                                  LeafBatch& out) {
    Camera cam;
    if (!cam.Set(camera, first, n, core_.sceneBox)) return false;
    core_.counters = {};
    out.leaves.clear();
    out.missed.clear();
    out.nRays = n;
    out.rayIndex.resize(n);
    if (n == 0) return true;
    rayOut_ = out.rayIndex.data();
    ClassifyBands(cam, out);
    rayOut_ = nullptr;
    return true;
}

void PinholeSubdivision::ClassifyBands(const Camera& cam, LeafBatch& out) {
    const uint32_t n = uint32_t(cam.last - cam.first);
    WorkerPool& pool = core_.pool;
    const int threads = pool.Start(n, kNoNode, out);
    // Bands of whole rows, taken in turn by whichever thread is free; band b's rays follow band
    // b - 1's.
    const uint32_t yFirst = cam.yFirst, rows = cam.yLast + 1 - yFirst;
    const uint32_t nBands = n < kBandedRaysMin ? 1 : std::min(rows, kBands);
    std::vector<PixelRect> bands;
    std::vector<uint32_t> slots;
    uint32_t slot = 0;
    for (uint32_t b = 0; b < nBands; ++b) {
        const PixelRect band{0, yFirst + uint32_t(uint64_t(rows) * b / nBands), cam.width,
                             yFirst + uint32_t(uint64_t(rows) * (b + 1) / nBands)};
        bands.push_back(band);
        slots.push_back(slot);
        slot += cam.Count(band);
    }
    // Per band: its part, its rays that got a leaf and those that did not.
    std::vector<Part*> parts;
    std::vector<RectOut> done(nBands);
    for (uint32_t b = 0; b < nBands; ++b) {
        parts.push_back(&pool.Queue(slots[b], [&, b](Worker& w) {
            // The band's slot counter and misses are this thread's until the band is done:
            // updating the bands' entries, which share cache lines, leaf by leaf from both
            // threads bounced the lines between the cores.
            RectOut band{slots[b], {}};
            ProcessRect(w, cam, bands[b], 0, band);
            done[b] = std::move(band);
        }));
    }
    pool.Run(threads);
    // The bands' slots close up over the rays that got no leaf.
    uint32_t used = 0;
    for (uint32_t b = 0; b < nBands; ++b) {
        const uint32_t shift = slots[b] - used;
        if (shift > 0) {
            std::copy(rayOut_ + slots[b], rayOut_ + done[b].slot, rayOut_ + used);
            Part& part = *parts[b];
            Worker& w = pool.WorkerOf(part);
            for (size_t l = part.leafBegin; l < part.leafEnd; ++l) w.leaves[l].rayBegin -= shift;
            part.begin -= shift;
        }
        used += done[b].slot - slots[b];
        out.missed.insert(out.missed.end(), done[b].missed.begin(), done[b].missed.end());
    }
    out.rayIndex.resize(used);
    pool.Join(out, threads);
    pool.Finish(0, core_.counters);
}

void PinholeSubdivision::ProcessRect(Worker& w, const Camera& cam, const PixelRect& rect, int depth,
                                     RectOut& out) {
    RectBeam beam;
    beam.nRays = cam.Count(rect);
    if (beam.nRays == 0) return;
    const ArenaMark release(w.stack);
    const int face = cam.CentreFace(rect);
    if (!cam.Bounds(rect, face, beam.tight, beam.corners)) {
        // Too wide for one frame: its halves look again. (A single pixel fits its own face.)
        PixelRect half[2];
        Camera::Halve(rect, half);
        for (const PixelRect& h : half) ProcessRect(w, cam, h, depth + 1, out);
        return;
    }
    const ListView list = core_.faceLists->Whole(face);
    beam.filtered = !KeepsMost(beam.tight, list);
    beam.own = beam.filtered ? w.Filter(beam.tight, list, false) : CutAtEnd(beam.tight, list);
    ProcessNode(w, cam, rect, face, depth, list, beam, out);
}

void PinholeSubdivision::ProcessNode(Worker& w, const Camera& cam, const PixelRect& rect, int face,
                                     int depth, const ListView& list, const RectBeam& beam,
                                     RectOut& out) {
    // The node's box only for a leaf: ChooseSplit reads its face and depth.
    Node node;
    node.face = uint8_t(face);
    node.depth = uint8_t(depth);
    int dim = 0;
    if (core_.cost.ChooseSplit(node, beam.tight, beam.nRays, beam.own, core_.params.minCandidates,
                               dim)) {
        SplitRect(w, cam, rect, beam.corners, face, depth, beam.own, out);
        return;
    }
    const ListView own = beam.filtered ? beam.own : w.Filter(beam.tight, list, false);
    // Rays that cannot reach a primitive get no leaf and are answered "no hit": all of a leaf
    // whose list is empty and, from a camera outside the scene box, those of a leaf on the
    // box's outline that miss it.
    const Reach reach = CountUpTo(own, beam.tight.hi[kDims]) == 0
                            ? Reach::kNone
                            : (cam.outside && !cam.AllReach(rect) ? Reach::kSome : Reach::kAll);
    if (reach == Reach::kSome && uint64_t(rect.x1 - rect.x0) * (rect.y1 - rect.y0) > kClipPixels) {
        // On the outline: halves, so that only pixels near it are tested one by one.
        SplitRect(w, cam, rect, beam.corners, face, depth, own, out);
        return;
    }
    node.box = beam.tight.ToBox5();
    EmitRect(w, cam, rect, node, own, beam.tight.hi[kDims], reach, out);
}

void PinholeSubdivision::SplitRect(Worker& w, const Camera& cam, const PixelRect& rect,
                                   const Corners& corners, int face, int depth,
                                   const ListView& list, RectOut& out) {
    PixelRect half[2];
    Camera::Halve(rect, half);
    const ArenaMark release(w.stack);
    RectBeam beam[2];
    cam.HalfBounds(rect, corners, half, face, beam);
    bool both = true;
    for (int j = 0; j < 2; ++j) {
        beam[j].nRays = cam.Count(half[j]);
        beam[j].filtered = !KeepsMost(beam[j].tight, list);
        both = both && beam[j].nRays > 0 && beam[j].filtered;
    }
    // Both halves' lists in one pass over the parent's, which is read once instead of twice.
    ListView own[2];
    const Bounds6 tight[2] = {beam[0].tight, beam[1].tight};
    const bool paired = both && FilterPairOnto(w.stack, tight, list, w.counters.boxTests, own);
    for (int j = 0; j < 2; ++j) {
        if (beam[j].nRays == 0) continue;
        const ArenaMark releaseHalf(w.stack);
        if (paired) {
            beam[j].own = own[j];
        } else {
            beam[j].own = beam[j].filtered ? w.Filter(beam[j].tight, list, false)
                                           : CutAtEnd(beam[j].tight, list);
        }
        ProcessNode(w, cam, half[j], face, depth + 1, list, beam[j], out);
    }
}

void PinholeSubdivision::EmitRect(Worker& w, const Camera& cam, const PixelRect& rect,
                                  const Node& node, const ListView& own, float endHi, Reach reach,
                                  RectOut& out) {
    RcLeaf leaf{};
    leaf.rayBegin = out.slot;
    rc_uint* to = rayOut_ + out.slot;
    for (uint32_t y = rect.y0; y < rect.y1; ++y) {
        uint64_t lo, hi;
        cam.RowSpan(rect, y, lo, hi);
        if (hi <= lo) continue;
        // A row's rays are consecutive (a loop the compiler vectorises).
        const uint32_t base = uint32_t(lo - cam.first), len = uint32_t(hi - lo);
        if (reach == Reach::kNone) {
            for (uint32_t k = 0; k < len; ++k) out.missed.push_back(base + k);
        } else if (reach == Reach::kSome) {
            const uint32_t x0 = uint32_t(lo - uint64_t(y) * cam.width);
            for (uint32_t k = 0; k < len; ++k) {
                if (cam.Reaches(x0 + k, y)) {
                    *to++ = base + k;
                } else {
                    out.missed.push_back(base + k);
                }
            }
        } else {
            for (uint32_t k = 0; k < len; ++k) to[k] = base + k;
            to += len;
        }
    }
    leaf.rayCount = uint32_t(to - (rayOut_ + out.slot));
    if (leaf.rayCount == 0) return;
    out.slot += leaf.rayCount;
    w.PushLeaf(leaf, w.NewNode(node.box, node.face, node.depth, false), own, endHi);
}

}  // namespace rayclass::classify
