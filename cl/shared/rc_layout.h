/* Every struct of rc_types.h and every field of each, in declaration order: the one list that
 * cl/layout_probe.cl (the device's sizeof, alignment and offsets) and tests/clrt/layout_test.cpp
 * (the host's) expand, so both sides report the same values in the same order. The test also
 * checks the list against the fields rc_types.h declares, so a field added there must be added
 * here. Expand with RC_LAYOUT_ENTRIES(STRUCT, FIELD): STRUCT(type) before each struct's fields,
 * FIELD(type, field) for each field. */
#ifndef RAYCLASS_RC_LAYOUT_H
#define RAYCLASS_RC_LAYOUT_H

#include "rc_types.h"

#define RC_LAYOUT_ENTRIES(STRUCT, FIELD) \
    STRUCT(RcTriangle)                   \
    FIELD(RcTriangle, v0)                \
    FIELD(RcTriangle, v1)                \
    FIELD(RcTriangle, v2)                \
    STRUCT(RcTriangleShading)            \
    FIELD(RcTriangleShading, n0)         \
    FIELD(RcTriangleShading, n1)         \
    FIELD(RcTriangleShading, n2)         \
    FIELD(RcTriangleShading, material)   \
    FIELD(RcTriangleShading, object)     \
    FIELD(RcTriangleShading, hasNormals) \
    FIELD(RcTriangleShading, pad)        \
    STRUCT(RcSphere)                     \
    FIELD(RcSphere, centerRadius)        \
    FIELD(RcSphere, material)            \
    FIELD(RcSphere, object)              \
    FIELD(RcSphere, pad0)                \
    FIELD(RcSphere, pad1)                \
    STRUCT(RcQuadric)                    \
    FIELD(RcQuadric, c0)                 \
    FIELD(RcQuadric, c1)                 \
    FIELD(RcQuadric, c2)                 \
    FIELD(RcQuadric, boxMin)             \
    FIELD(RcQuadric, boxMax)             \
    FIELD(RcQuadric, material)           \
    FIELD(RcQuadric, object)             \
    FIELD(RcQuadric, kind)               \
    FIELD(RcQuadric, pad1)               \
    STRUCT(RcPatchBox)                   \
    FIELD(RcPatchBox, points)            \
    FIELD(RcPatchBox, closedU)           \
    FIELD(RcPatchBox, closedV)           \
    FIELD(RcPatchBox, patch)             \
    FIELD(RcPatchBox, range)             \
    FIELD(RcPatchBox, pad2)              \
    FIELD(RcPatchBox, boxMin)            \
    FIELD(RcPatchBox, boxMax)            \
    FIELD(RcPatchBox, material)          \
    FIELD(RcPatchBox, object)            \
    FIELD(RcPatchBox, kind)              \
    FIELD(RcPatchBox, pad1)              \
    STRUCT(RcMaterial)                   \
    FIELD(RcMaterial, kd)                \
    FIELD(RcMaterial, ks)                \
    FIELD(RcMaterial, kr)                \
    FIELD(RcMaterial, kt)                \
    FIELD(RcMaterial, emission)          \
    FIELD(RcMaterial, shininess)         \
    FIELD(RcMaterial, ior)               \
    FIELD(RcMaterial, fresnel)           \
    FIELD(RcMaterial, pad)               \
    STRUCT(RcLight)                      \
    FIELD(RcLight, position)             \
    FIELD(RcLight, intensity)            \
    STRUCT(RcCamera)                     \
    FIELD(RcCamera, position)            \
    FIELD(RcCamera, forward)             \
    FIELD(RcCamera, right)               \
    FIELD(RcCamera, up)                  \
    FIELD(RcCamera, tanHalfFovX)         \
    FIELD(RcCamera, tanHalfFovY)         \
    FIELD(RcCamera, width)               \
    FIELD(RcCamera, height)              \
    FIELD(RcCamera, windowX)             \
    FIELD(RcCamera, windowY)             \
    FIELD(RcCamera, windowWidth)         \
    FIELD(RcCamera, windowHeight)        \
    STRUCT(RcRay)                        \
    FIELD(RcRay, origin)                 \
    FIELD(RcRay, direction)              \
    STRUCT(RcRayInfo)                    \
    FIELD(RcRayInfo, weight)             \
    FIELD(RcRayInfo, depth)              \
    FIELD(RcRayInfo, kind)               \
    FIELD(RcRayInfo, pad0)               \
    FIELD(RcRayInfo, pad1)               \
    STRUCT(RcHit)                        \
    FIELD(RcHit, t)                      \
    FIELD(RcHit, prim)                   \
    FIELD(RcHit, u)                      \
    FIELD(RcHit, v)                      \
    STRUCT(RcRenderParams)               \
    FIELD(RcRenderParams, nTriangles)    \
    FIELD(RcRenderParams, nSpheres)      \
    FIELD(RcRenderParams, nQuadrics)     \
    FIELD(RcRenderParams, nLights)       \
    FIELD(RcRenderParams, maxDepth)      \
    FIELD(RcRenderParams, minWeight)     \
    FIELD(RcRenderParams, pad0)          \
    FIELD(RcRenderParams, pad1)          \
    FIELD(RcRenderParams, ambient)       \
    FIELD(RcRenderParams, background)    \
    STRUCT(RcLeaf)                       \
    FIELD(RcLeaf, rayBegin)              \
    FIELD(RcLeaf, rayCount)              \
    FIELD(RcLeaf, candBegin)             \
    FIELD(RcLeaf, candCount)             \
    FIELD(RcLeaf, face)                  \
    FIELD(RcLeaf, node)                  \
    FIELD(RcLeaf, pad0)                  \
    FIELD(RcLeaf, pad1)                  \
    STRUCT(RcCandidate)                  \
    FIELD(RcCandidate, prim)             \
    FIELD(RcCandidate, nearX)            \
    STRUCT(RcTriangleBlock16)            \
    FIELD(RcTriangleBlock16, v0x)        \
    FIELD(RcTriangleBlock16, v0y)        \
    FIELD(RcTriangleBlock16, v0z)        \
    FIELD(RcTriangleBlock16, e1x)        \
    FIELD(RcTriangleBlock16, e1y)        \
    FIELD(RcTriangleBlock16, e1z)        \
    FIELD(RcTriangleBlock16, e2x)        \
    FIELD(RcTriangleBlock16, e2y)        \
    FIELD(RcTriangleBlock16, e2z)        \
    FIELD(RcTriangleBlock16, prim)       \
    FIELD(RcTriangleBlock16, otherMask)  \
    FIELD(RcTriangleBlock16, count)      \
    FIELD(RcTriangleBlock16, nearX)      \
    FIELD(RcTriangleBlock16, pad)        \
    STRUCT(RcBvh8Node)                   \
    FIELD(RcBvh8Node, loX)               \
    FIELD(RcBvh8Node, loY)               \
    FIELD(RcBvh8Node, loZ)               \
    FIELD(RcBvh8Node, hiX)               \
    FIELD(RcBvh8Node, hiY)               \
    FIELD(RcBvh8Node, hiZ)               \
    FIELD(RcBvh8Node, child)             \
    FIELD(RcBvh8Node, nChildren)         \
    FIELD(RcBvh8Node, pad)               \
    STRUCT(RcKdNode)                     \
    FIELD(RcKdNode, word)                \
    FIELD(RcKdNode, data)                \
    STRUCT(RcCone)                       \
    FIELD(RcCone, apex)                  \
    FIELD(RcCone, axis)

#endif
