// The eye rays' first hits by rasterization (Lessig 2004, sec. 4.2; docs/design.md): every
// primitive is drawn as a hull that covers every pixel whose eye ray can hit it, and the fragment
// shader tests that pixel's eye ray exactly against the primitive (the formulas of
// geometry/intersect.h and cl/intersect.cl, in float), writes the hit distance as depth and keeps,
// through the depth test, the nearest hit per pixel.
//
// - Eye rays: the formula of RcCamera (cl/camera.cl) per pixel, in the fragment shader.
// - Triangles are drawn themselves, inflated in screen space (a geometry shader) by 0.75 pixel so
//   that every pixel centre within half a pixel diagonal of the projection is covered: an edge-on
//   triangle becomes its inflated bounding rectangle.
// - Spheres and quadrics are drawn as hulls: a screen-aligned square around the projection of the
//   bounding sphere (what a GL point of computed size covers), the front faces of the bounding
//   box grown by a pixel footprint (back faces culled, so each ray is tested once), or a
//   screen-aligned billboard over the box's angular extents. A hull that reaches within `zNear` of
//   the eye plane covers the whole screen (the exact test decides).
// - Patch boxes are drawn as the hull of their control points' box (box by default, or the
//   sphere or billboard hull when asked), and the fragment shader runs the Newton iteration of
//   cl/patch.cl on the pixel's eye ray.
// - Depth = world distance times DepthScale(): by default the largest power of two 2^-k that keeps
//   every distance from the eye to the scene bounds below 1, so a float depth buffer holds t * 2^-k
//   exactly and the depth test compares hit distances exactly; equal distances keep the primitive
//   drawn first, the lower id, as every query path does.
// - Ids are full 32-bit global primitive ids (triangles, spheres, quadrics, patch boxes; RC_NO_HIT
//   on a miss).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "rayclass/raster/gl.h"
#include "rayclass/render/device_scene.h"
#include "rayclass/render/eye_hits.h"
#include "rayclass/render/options.h"
#include "rayclass/scene/scene.h"
#include "rc_types.h"

namespace rayclass::raster {

enum class Hull { Sphere, Box, Billboard, Auto };
inline constexpr render::Named<Hull> kHulls[] = {{"sphere", Hull::Sphere},
                                                 {"box", Hull::Box},
                                                 {"billboard", Hull::Billboard},
                                                 {"auto", Hull::Auto}};

// "sphere", "box", "billboard", "auto"; throws rayclass::UsageError on anything else.
Hull ParseHull(const std::string& name);
const char* HullName(Hull hull);

struct RasterOptions {
    // Hull of spheres, quadrics and patch boxes. Auto: spheres by their bounding sphere (the
    // sphere itself), quadrics by their clip box, patch boxes by their box.
    Hull hull = Hull::Auto;
    // Depth buffer: 32 (float, default), 24 or 16 (fixed point; for precision studies).
    int depthBits = 32;
    // Distance-to-depth factor; 0 derives it from the scene bounds and the camera (see above).
    // Hits farther than 1 / depthScale are lost (depth clamps to 1, the cleared value).
    double depthScale = 0;
    // Count fragment-shader invocations and exact hits with atomic counters (costs time).
    bool countFragments = false;
    // Front-to-back slabs (1 = none): primitives sorted by their nearest possible distance and
    // drawn in `slabs` groups; between groups the depth is copied to a texture and a fragment whose
    // hull cannot come nearer than the current hit skips its exact test.
    uint32_t slabs = 1;
};

// The depth-buffer settings of `options` that can give pixels a wrong nearest hit on `scene`
// seen from `eye`, one message per reason, without a prefix (empty: safe). With D the scene's
// depth range (the distance from the eye to the farthest corner of the scene bounds), s the depth
// scale (0: the automatic one above) and b the depth bits, a setting is unsafe when
//  - s * D >= 1: hits farther than 1 / s are lost (their depth clamps to the cleared 1);
//  - b is 16 or 24 and one depth step, 1 / (s * (2^b - 1)) world units, exceeds D * 2^-20 (about
//    8 to 16 float ulps of the farthest distance; the automatic scale's 24-bit step is at most
//    D * 2^-23): surfaces nearer to each other than a step along a ray may swap ids;
//  - b is 32 and s is not a power of two: t * s rounds, so distances no longer compare exactly
//    and surfaces within a float step may swap ids.
// The defaults (32-bit float depth, automatic scale) are safe on every scene.
std::vector<std::string> DepthWarnings(const scene::Scene& scene, const glm::vec3& eye,
                                       const RasterOptions& options);

struct RasterStats {
    double uploadS = 0;      // camera uniforms, clearing
    double drawS = 0;        // every draw call until glFinish
    double readbackS = 0;    // glReadPixels of ids, distances and barycentrics
    double totalS = 0;       // the whole Render call
    uint64_t fragments = 0;  // fragment-shader invocations (countFragments)
    uint64_t tested = 0;     // fragments that ran the exact test (not skipped by slabs)
    uint64_t exactHits = 0;  // fragments whose exact test hit
    double depthScale = 0;
};

class RasterPass {
  public:
    // Uploads the scene's primitives to `gl`'s context (current on this thread).
    RasterPass(GlContext& gl, const scene::Scene& scene, const RasterOptions& options = {});
    ~RasterPass();
    RasterPass(const RasterPass&) = delete;
    RasterPass& operator=(const RasterPass&) = delete;

    // One frame seen from `camera` (its width x height, whatever its window): the nearest hit of
    // every pixel's eye ray, row-major with row 0 at the top, as the eye-ray query would return it:
    // t along the unit direction, the global primitive id (RC_NO_HIT and t = +inf on a miss),
    // barycentrics for triangles, the box's local (u, v) for patch boxes (0 otherwise).
    std::vector<RcHit> Render(const RcCamera& camera, RasterStats* stats = nullptr);

    // The factor of the last Render.
    double DepthScale() const { return depthScale_; }
    const RasterOptions& Options() const { return options_; }

  private:
    enum Kind { kTriangles = 0, kSpheres = 1, kQuadrics = 2, kPatchBoxes = 3 };
    static constexpr int kKinds = 4;
    using Programs = std::array<GLuint, kKinds>;  // per kind; 0: no primitive of the kind
    GLuint Program(Kind kind, Hull hull, bool slabPass);
    void EnsureFramebuffer(uint32_t width, uint32_t height);
    void PrepareSlabs(const RcCamera& camera);
    // The stages of Render: the programs with the camera's uniforms, cleared targets, the draw
    // calls, and the hits read back.
    Programs SetUpPrograms(const RcCamera& camera);
    void ClearTargets();
    void Draw(const Programs& programs);
    std::vector<RcHit> ReadHits();

    GlContext& gl_;
    RasterOptions options_;
    uint32_t count_[kKinds] = {0, 0, 0, 0};
    uint32_t base_[kKinds] = {0, 0, 0, 0};
    Bounds3f bounds_;
    GlBuffer primitives_[kKinds];
    GlBuffer slabOrder_[kKinds];
    GlBuffer counters_;
    GlVertexArray vao_;
    GlFramebuffer fbo_;
    GlTexture idTex_, distTex_, uvTex_, depthTex_, prevDepthTex_;
    GlFramebuffer copyFbo_;
    uint32_t width_ = 0, height_ = 0;
    double depthScale_ = 0;
    std::map<std::tuple<int, int, bool>, GlProgram> programs_;
    // Slabs: per kind, the draw ranges of each slab in the sorted order.
    std::vector<std::vector<std::pair<uint32_t, uint32_t>>> slabRanges_;
    std::vector<scene::Sphere> sphereHulls_[kKinds];  // per primitive: bounding sphere (slabs)
};

// The renderer's generation-0 hook: hits of the eye rays from a RasterPass.
class RasterEyeHits final : public render::EyeHitSource {
  public:
    RasterEyeHits(GlContext& gl, const RasterOptions& options) : gl_(gl), options_(options) {}
    std::string Name() const override { return "raster"; }
    std::vector<RcHit> FindHits(const scene::Scene& scene, const render::CameraBasis& camera,
                                render::RenderStats& stats) override;

  private:
    GlContext& gl_;
    RasterOptions options_;
};

}  // namespace rayclass::raster
