/* Structs shared by the host (C++20) and the OpenCL kernels (OpenCL C 1.2), declared once.
 *
 * Rules that keep both compilers agreeing on the layout: no bool, size_t or float3 (a float3 is
 * 16 bytes in OpenCL C); vectors are rc_float4 (16-byte aligned on both sides); every struct
 * states its size, and src/clrt/layout.cpp checks sizeof/offsetof on the host while
 * tests/clrt/layout_test.cpp checks them on the device. */
#ifndef RAYCLASS_RC_TYPES_H
#define RAYCLASS_RC_TYPES_H

#ifdef __OPENCL_VERSION__
typedef uint rc_uint;
typedef float4 rc_float4;
#else
#include <cstdint>
typedef uint32_t rc_uint;
struct alignas(16) rc_float4 {
    float x, y, z, w;
};
#endif

/* Marks "no primitive" in hits, id buffers and the id AOV. */
#define RC_NO_HIT 0xFFFFFFFFu

/* Primitive ids are global: triangles [0, nTriangles), then spheres, then quadrics and patch
 * boxes. Equal hit
 * distances are broken by the lower id in every query path. */

/* A triangle's vertices in world space (w unused). 48 bytes. */
typedef struct RcTriangle {
    rc_float4 v0, v1, v2;
} RcTriangle;

/* What shading needs of a triangle: vertex normals (w = 0 for all three when the mesh has none,
 * then the geometric normal is used), material and object. 64 bytes. */
typedef struct RcTriangleShading {
    rc_float4 n0, n1, n2;
    rc_uint material;
    rc_uint object;
    rc_uint hasNormals;
    rc_uint pad;
} RcTriangleShading;

/* centerRadius = (cx, cy, cz, r). 32 bytes. */
typedef struct RcSphere {
    rc_float4 centerRadius;
    rc_uint material;
    rc_uint object;
    rc_uint pad0, pad1;
} RcSphere;

/* Q(p) = A x^2 + B y^2 + C z^2 + D xy + E xz + F yz + G x + H y + I z + J = 0, clipped to the box
 * [boxMin, boxMax]. c0 = (A, B, C, D), c1 = (E, F, G, H), c2 = (I, J, 0, 0). kind =
 * RC_ANALYTIC_QUADRIC. 96 bytes. */
typedef struct RcQuadric {
    rc_float4 c0, c1, c2;
    rc_float4 boxMin, boxMax;
    rc_uint material;
    rc_uint object;
    rc_uint kind;
    rc_uint pad1;
} RcQuadric;

/* The analytic buffer the kernels get as `quadrics` holds 96-byte records, one per primitive id
 * after the spheres (RcRenderParams.nQuadrics of them): the quadrics, then the patch boxes
 * (RcPatchBox), told apart by kind at the same offset, and after the records the patch boxes'
 * control points. So patches reach every query without a kernel argument of their own. */
#define RC_ANALYTIC_QUADRIC 0u
#define RC_ANALYTIC_PATCH_BOX 1u

/* A patch box (scene::PatchBox): a rational bicubic Bezier patch of its own, whose 16 control
 * points (w x, w y, w z, w), point (i, j) weighing B_i(u) B_j(v), are the rc_float4s
 * [points + 4 i + j] of the analytic buffer, and whose control points' box [boxMin, boxMax] is
 * the primitive the accelerations see. A hit counts for local u in [0, 1), or [0, 1] when
 * closedU (the box reaches the far edge of its patch), v alike; RcHit.u, v are the local
 * parameters. range = (u0, u1, v0, v1), the box's part of its patch. 96 bytes. */
typedef struct RcPatchBox {
    rc_uint points;
    rc_uint closedU;
    rc_uint closedV;
    rc_uint patch;
    rc_float4 range;
    rc_float4 pad2;
    rc_float4 boxMin, boxMax;
    rc_uint material;
    rc_uint object;
    rc_uint kind;
    rc_uint pad1;
} RcPatchBox;

/* Whitted material. kd, ks: Phong diffuse and specular (rgb); kr, kt: mirror reflection and
 * transmission (rgb); emission (rgb). With fresnel != 0 the reflected share of kt follows the
 * dielectric Fresnel term of ior. 96 bytes. */
typedef struct RcMaterial {
    rc_float4 kd, ks, kr, kt, emission;
    float shininess;
    float ior;
    rc_uint fresnel;
    rc_uint pad;
} RcMaterial;

/* A point light: position (w unused) and rgb intensity (w unused). 32 bytes. */
typedef struct RcLight {
    rc_float4 position;
    rc_float4 intensity;
} RcLight;

/* Pinhole camera. The eye ray of pixel (x, y) (row 0 at the top) is
 * normalize(forward + sx * right + sy * up), sx = (2 (x + 0.5) / width - 1) * tanHalfFovX,
 * sy = (1 - 2 (y + 0.5) / height) * tanHalfFovY: the same formula in every eye-ray path.
 * right/up/forward are unit vectors. The render covers the window of windowWidth x windowHeight
 * pixels at (windowX, windowY) of the width x height image (all of it unless it is a crop or
 * tile): ray i of a generation-0 batch is the window's pixel i, row-major, and its direction is
 * the full image's, so a crop's pixels are those of a whole render. 96 bytes. */
typedef struct RcCamera {
    rc_float4 position;
    rc_float4 forward, right, up;
    float tanHalfFovX;
    float tanHalfFovY;
    rc_uint width;
    rc_uint height;
    rc_uint windowX;
    rc_uint windowY;
    rc_uint windowWidth;
    rc_uint windowHeight;
} RcCamera;

/* Kinds of rays, for statistics and shading decisions. */
#define RC_RAY_EYE 0u
#define RC_RAY_SHADOW 1u
#define RC_RAY_REFLECTION 2u
#define RC_RAY_REFRACTION 3u

/* A ray of a generation is split over two arrays with one index: RcRay holds what every
 * intersection query and the host's ray classification read, RcRayInfo what only ray
 * generation and shading touch, so a query or the classification pays for 32 bytes a ray, not
 * for a whole 64-byte cache line (the host classification streams through the rays, and reads
 * them measurably slower at a 64-byte stride than at 32). */

/* Where shading writes ray i's secondary ray k (0 reflection, 1 refraction) of a batch: runs of
 * RC_SECONDARY_RUN rays' reflections, each followed by the same rays' refractions (128 RcRay or
 * RcRayInfo records fill a 4 KiB page), so that where nothing refracts half of the secondary
 * arrays is never written and its pages never faulted in. spawned[2i + k] flags the slot. A
 * batch of n rays takes 2 * RC_SECONDARY_RUN * ceil(n / RC_SECONDARY_RUN) slots. */
#define RC_SECONDARY_RUN 128u
#define RC_SECONDARY_SLOT(i, k)                                                  \
    ((i) / RC_SECONDARY_RUN * (2u * RC_SECONDARY_RUN) + RC_SECONDARY_RUN * (k) + \
     (i) % RC_SECONDARY_RUN)

/* origin.w = tmin (0 for spawned rays: their origin is already offset), direction.w = tmax (unit
 * direction). The layout of classify::Ray. 32 bytes. */
typedef struct RcRay {
    rc_float4 origin;
    rc_float4 direction;
} RcRay;

/* The rest of a ray: weight = rgb throughput from the eye (w unused), depth = 0 for eye rays,
 * kind (RC_RAY_*). Eye rays have none: a shading kernel given no info buffer takes its rays for
 * eye rays (rc_ray_info), which saves generation 0 writing 32 bytes a pixel. The host keeps each
 * ray's pixel. 32 bytes. */
typedef struct RcRayInfo {
    rc_float4 weight;
    rc_uint depth;
    rc_uint kind;
    rc_uint pad0, pad1;
} RcRayInfo;

/* Nearest hit of a ray: distance t along the unit direction, primitive id (RC_NO_HIT on a miss),
 * and the barycentric (u, v) for triangles. 16 bytes. */
typedef struct RcHit {
    float t;
    rc_uint prim;
    float u, v;
} RcHit;

/* A shadow ray is split the same way: an RcRay from the offset hit point (tmin 0) toward the
 * light (tmax = distance to the light), all the occlusion query and the classification read,
 * and a float4 of the same index holding the light's contribution that becomes visible if the
 * ray is unblocked (rgb; w = 1 when the slot is live). An empty slot is all zeros in both: its
 * ray has no direction (it misses at once) and it contributes nothing. */

/* Scalar parameters of a render passed to every kernel. 64 bytes. */
typedef struct RcRenderParams {
    rc_uint nTriangles;
    rc_uint nSpheres;
    rc_uint nQuadrics; /* records of the analytic buffer: quadrics and patch boxes */
    rc_uint nLights;
    rc_uint maxDepth;
    float minWeight;
    rc_uint pad0, pad1;
    rc_float4 ambient;    /* rgb ambient light, times kd */
    rc_float4 background; /* rgb radiance of rays that leave the scene */
} RcRenderParams;

/* One leaf of the ray classification (classify/hierarchy.h): its rays are
 * rayIndex[rayBegin, rayBegin + rayCount) (indices into the generation's ray buffer), its
 * candidates are candidates[candBegin, candBegin + candCount), sorted by nearX. face = 2 * axis +
 * (direction negative) is the direction-cube face of all its rays; node is the hierarchy node it
 * came from (for statistics and debugging). 32 bytes. */
typedef struct RcLeaf {
    rc_uint rayBegin;
    rc_uint rayCount;
    rc_uint candBegin;
    rc_uint candCount;
    rc_uint face;
    rc_uint node;
    rc_uint pad0, pad1;
} RcLeaf;

/* A candidate of a leaf: the primitive's global id and the near side of its (padded) bounding
 * box along the leaf face's main axis, in the face frame (X = +p_axis or -p_axis). A query may stop
 * before a candidate once its nearest hit's X is below nearX: no later candidate can be nearer.
 * 8 bytes. */
typedef struct RcCandidate {
    rc_uint prim;
    float nearX;
} RcCandidate;

/* Sixteen consecutive candidates of one leaf in structure-of-arrays form, so the vertex-style
 * query tests a ray against all sixteen with float16 arithmetic. Triangle lanes hold v0 and the
 * edges e1 = v1 - v0, e2 = v2 - v0; lanes of spheres and quadrics (bits of otherMask) and unused
 * lanes hold zero edges, which the triangle test rejects (det = 0). nearX = the first lane's
 * candidate nearX, the smallest of the block. 704 bytes. */
typedef struct RcTriangleBlock16 {
    float v0x[16], v0y[16], v0z[16];
    float e1x[16], e1y[16], e1z[16];
    float e2x[16], e2y[16], e2z[16];
    rc_uint prim[16];
    rc_uint otherMask;
    rc_uint count;
    float nearX;
    rc_uint pad[13];
} RcTriangleBlock16;

/* A node of the 8-wide bounding volume hierarchy that cl/bvh.cl walks (--accel bvh;
 * include/rayclass/bvh/bvh.h): the boxes of up to eight children as structure of arrays, one
 * float8 per bound, so that one slab test covers them all. Boxes are padded so that float rounding
 * in the slab test never loses a primitive the intersection routines would hit. child[c] for
 * c < nChildren: another node's index, or RC_BVH8_LEAF | (count - 1) << RC_BVH8_COUNT_SHIFT | first
 * for a leaf whose primitives' global ids are primIndex[first, first + count). 256 bytes. */
#define RC_BVH8_LEAF 0x80000000u
#define RC_BVH8_COUNT_SHIFT 27
#define RC_BVH8_MAX_LEAF 16u           /* primitives in a leaf */
#define RC_BVH8_FIRST_MASK 0x07FFFFFFu /* primIndex positions a leaf can start at */
typedef struct RcBvh8Node {
    float loX[8], loY[8], loZ[8];
    float hiX[8], hiY[8], hiZ[8];
    rc_uint child[8];
    rc_uint nChildren;
    rc_uint pad[7];
} RcBvh8Node;

/* A node of the SAH kd-tree that cl/kdtree.cl walks (--accel kdtree; include/rayclass/accel/
 * kdtree.h). word & 3 is the split axis of an inner node, 3 for a leaf; word >> 2 is the index
 * of an inner node's upper child (its lower child is the next node) or a leaf's primitive
 * count. data is an inner node's split position (its float's bits) or where a leaf's primitives
 * begin, their position in the primitive index list. 8 bytes. */
#define RC_KD_LEAF 3u
typedef struct RcKdNode {
    rc_uint word;
    rc_uint data;
} RcKdNode;

/* The primitives of the 8-wide hierarchy's leaves as cl/bvh.cl tests them, sized to each leaf:
 * a leaf of count primitives is a run of RC_BVH_LEAF_ARRAYS * count 32-bit words, structure of
 * arrays over exactly its primitives, v0x[count], v0y, v0z, e1x, e1y, e1z, e2x, e2y, e2z, prim
 * (floats, then global ids), so that eight-lane loads cover it and a leaf visit reads only the
 * cache lines its primitives fill. Triangle lanes hold v0 and the edges e1 = v1 - v0, e2 = v2 - v0;
 * sphere and quadric lanes hold zero edges, which the triangle test rejects (det = 0). Runs
 * start at multiples of RC_BVH_LEAF_ALIGN words, which the kernels' leaf references count in
 * place of the primIndex position (include/rayclass/bvh/leaf_blocks.h); RC_BVH_LEAF_TAIL zero
 * words follow the last run, so that an eight-lane load from any lane of a run stays in the
 * buffer. */
#define RC_BVH_LEAF_ARRAYS 10u
#define RC_BVH_LEAF_ALIGN 4u
#define RC_BVH_LEAF_TAIL 8u

/* A cone enclosing a tile of rays (--accel cones; include/rayclass/accel/cones.h): every ray's
 * origin inside it and every direction within its half-angle phi of its axis, so the cone holds
 * every point of every ray. apex.w = tan^2 phi, or -1 for a cone of 90 degrees or more, which
 * culls nothing; axis is a unit vector, axis.w = 1 / sin phi. 32 bytes. */
typedef struct RcCone {
    rc_float4 apex;
    rc_float4 axis;
} RcCone;

#endif
