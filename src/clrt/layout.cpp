// Compile-time checks of the host layout of the structs shared with the kernels (rc_types.h):
// the sizes its comments state, 16-byte alignment wherever a rc_float4 is a member, and the
// offsets that depend on padding. tests/clrt/layout_test.cpp checks the same on the device.
#include <cstddef>

#include "rc_types.h"

static_assert(sizeof(rc_float4) == 16 && alignof(rc_float4) == 16);
static_assert(sizeof(rc_uint) == 4);

static_assert(sizeof(RcTriangle) == 48);
static_assert(sizeof(RcTriangleShading) == 64);
static_assert(sizeof(RcSphere) == 32);
static_assert(sizeof(RcQuadric) == 96);
static_assert(sizeof(RcPatchBox) == 96);
static_assert(sizeof(RcMaterial) == 96);
static_assert(sizeof(RcLight) == 32);
static_assert(sizeof(RcCamera) == 96);
static_assert(sizeof(RcRay) == 32);
static_assert(sizeof(RcRayInfo) == 32);
static_assert(sizeof(RcHit) == 16);
static_assert(sizeof(RcRenderParams) == 64);
static_assert(sizeof(RcLeaf) == 32);
static_assert(sizeof(RcCandidate) == 8);
static_assert(sizeof(RcTriangleBlock16) == 704);
static_assert(sizeof(RcBvh8Node) == 256);
static_assert(sizeof(RcKdNode) == 8);
static_assert(sizeof(RcCone) == 32 && alignof(RcCone) == 16);

static_assert(alignof(RcTriangle) == 16 && alignof(RcTriangleShading) == 16 &&
              alignof(RcSphere) == 16 && alignof(RcQuadric) == 16 && alignof(RcMaterial) == 16 &&
              alignof(RcLight) == 16 && alignof(RcCamera) == 16 && alignof(RcRay) == 16 &&
              alignof(RcRayInfo) == 16 && alignof(RcRenderParams) == 16);
static_assert(alignof(RcHit) == 4);

// Scalars after the vectors, and the vectors of RcRenderParams after its eight scalars.
static_assert(offsetof(RcTriangleShading, material) == 48);
static_assert(offsetof(RcSphere, material) == 16);
static_assert(offsetof(RcQuadric, material) == 80);
// The analytic buffer's records tell their kind at one offset.
static_assert(offsetof(RcPatchBox, kind) == offsetof(RcQuadric, kind));
static_assert(offsetof(RcPatchBox, boxMin) == offsetof(RcQuadric, boxMin));
static_assert(offsetof(RcMaterial, shininess) == 80);
static_assert(offsetof(RcCamera, tanHalfFovX) == 64);
static_assert(offsetof(RcRayInfo, depth) == 16);
static_assert(offsetof(RcRenderParams, ambient) == 32);
