/* Test-only kernel (tests/clrt/layout_test.cpp): the device compiler's view of every struct in
 * rc_types.h. For each struct it writes sizeof, alignment and the offset of every field, in the
 * order of RC_LAYOUT_ENTRIES in the test; out[0] is the number of values that follow. */
#include "rc_types.h"

#define RC_PUT(value) out[++n] = (uint)(value)
#define RC_STRUCT(type)   \
    RC_PUT(sizeof(type)); \
    RC_PUT(__alignof__(type))
#define RC_FIELD(type, field) RC_PUT(__builtin_offsetof(type, field))

__kernel void rc_layout_probe(__global uint* out) {
    if (get_global_id(0) != 0) return;
    uint n = 0;

    RC_STRUCT(RcTriangle);
    RC_FIELD(RcTriangle, v0);
    RC_FIELD(RcTriangle, v1);
    RC_FIELD(RcTriangle, v2);

    RC_STRUCT(RcTriangleShading);
    RC_FIELD(RcTriangleShading, n0);
    RC_FIELD(RcTriangleShading, n1);
    RC_FIELD(RcTriangleShading, n2);
    RC_FIELD(RcTriangleShading, material);
    RC_FIELD(RcTriangleShading, object);
    RC_FIELD(RcTriangleShading, hasNormals);
    RC_FIELD(RcTriangleShading, pad);

    RC_STRUCT(RcSphere);
    RC_FIELD(RcSphere, centerRadius);
    RC_FIELD(RcSphere, material);
    RC_FIELD(RcSphere, object);
    RC_FIELD(RcSphere, pad0);
    RC_FIELD(RcSphere, pad1);

    RC_STRUCT(RcQuadric);
    RC_FIELD(RcQuadric, c0);
    RC_FIELD(RcQuadric, c1);
    RC_FIELD(RcQuadric, c2);
    RC_FIELD(RcQuadric, boxMin);
    RC_FIELD(RcQuadric, boxMax);
    RC_FIELD(RcQuadric, material);
    RC_FIELD(RcQuadric, object);
    RC_FIELD(RcQuadric, pad0);
    RC_FIELD(RcQuadric, pad1);

    RC_STRUCT(RcMaterial);
    RC_FIELD(RcMaterial, kd);
    RC_FIELD(RcMaterial, ks);
    RC_FIELD(RcMaterial, kr);
    RC_FIELD(RcMaterial, kt);
    RC_FIELD(RcMaterial, emission);
    RC_FIELD(RcMaterial, shininess);
    RC_FIELD(RcMaterial, ior);
    RC_FIELD(RcMaterial, fresnel);
    RC_FIELD(RcMaterial, pad);

    RC_STRUCT(RcLight);
    RC_FIELD(RcLight, position);
    RC_FIELD(RcLight, intensity);

    RC_STRUCT(RcCamera);
    RC_FIELD(RcCamera, position);
    RC_FIELD(RcCamera, forward);
    RC_FIELD(RcCamera, right);
    RC_FIELD(RcCamera, up);
    RC_FIELD(RcCamera, tanHalfFovX);
    RC_FIELD(RcCamera, tanHalfFovY);
    RC_FIELD(RcCamera, width);
    RC_FIELD(RcCamera, height);

    RC_STRUCT(RcRay);
    RC_FIELD(RcRay, origin);
    RC_FIELD(RcRay, direction);

    RC_STRUCT(RcRayInfo);
    RC_FIELD(RcRayInfo, weight);
    RC_FIELD(RcRayInfo, depth);
    RC_FIELD(RcRayInfo, kind);
    RC_FIELD(RcRayInfo, pad0);
    RC_FIELD(RcRayInfo, pad1);

    RC_STRUCT(RcHit);
    RC_FIELD(RcHit, t);
    RC_FIELD(RcHit, prim);
    RC_FIELD(RcHit, u);
    RC_FIELD(RcHit, v);

    RC_STRUCT(RcRenderParams);
    RC_FIELD(RcRenderParams, nTriangles);
    RC_FIELD(RcRenderParams, nSpheres);
    RC_FIELD(RcRenderParams, nQuadrics);
    RC_FIELD(RcRenderParams, nLights);
    RC_FIELD(RcRenderParams, maxDepth);
    RC_FIELD(RcRenderParams, minWeight);
    RC_FIELD(RcRenderParams, pad0);
    RC_FIELD(RcRenderParams, pad1);
    RC_FIELD(RcRenderParams, ambient);
    RC_FIELD(RcRenderParams, background);
    RC_STRUCT(RcLeaf);
    RC_FIELD(RcLeaf, rayBegin);
    RC_FIELD(RcLeaf, rayCount);
    RC_FIELD(RcLeaf, candBegin);
    RC_FIELD(RcLeaf, candCount);
    RC_FIELD(RcLeaf, face);
    RC_FIELD(RcLeaf, node);
    RC_FIELD(RcLeaf, pad0);
    RC_FIELD(RcLeaf, pad1);
    RC_STRUCT(RcCandidate);
    RC_FIELD(RcCandidate, prim);
    RC_FIELD(RcCandidate, nearX);
    RC_STRUCT(RcTriangleBlock16);
    RC_FIELD(RcTriangleBlock16, v0x);
    RC_FIELD(RcTriangleBlock16, v0y);
    RC_FIELD(RcTriangleBlock16, v0z);
    RC_FIELD(RcTriangleBlock16, e1x);
    RC_FIELD(RcTriangleBlock16, e1y);
    RC_FIELD(RcTriangleBlock16, e1z);
    RC_FIELD(RcTriangleBlock16, e2x);
    RC_FIELD(RcTriangleBlock16, e2y);
    RC_FIELD(RcTriangleBlock16, e2z);
    RC_FIELD(RcTriangleBlock16, prim);
    RC_FIELD(RcTriangleBlock16, otherMask);
    RC_FIELD(RcTriangleBlock16, count);
    RC_FIELD(RcTriangleBlock16, nearX);
    RC_FIELD(RcTriangleBlock16, pad);
    RC_STRUCT(RcBvh8Node);
    RC_FIELD(RcBvh8Node, loX);
    RC_FIELD(RcBvh8Node, loY);
    RC_FIELD(RcBvh8Node, loZ);
    RC_FIELD(RcBvh8Node, hiX);
    RC_FIELD(RcBvh8Node, hiY);
    RC_FIELD(RcBvh8Node, hiZ);
    RC_FIELD(RcBvh8Node, child);
    RC_FIELD(RcBvh8Node, nChildren);
    RC_FIELD(RcBvh8Node, pad);

    out[0] = n;
}
