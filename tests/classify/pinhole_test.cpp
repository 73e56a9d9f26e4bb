#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "classify_support.h"
#include "rayclass/classify/hierarchy.h"
#include "rayclass/classify/stats.h"

namespace rayclass::classify {
namespace {

rc_float4 F4(const glm::vec3& v) { return {v.x, v.y, v.z, 0.0f}; }

RcCamera MakeCamera(glm::vec3 eye, glm::vec3 forward, glm::vec3 upHint, float fovYDegrees,
                    uint32_t width, uint32_t height) {
    forward = glm::normalize(forward);
    const glm::vec3 right = glm::normalize(glm::cross(forward, upHint));
    RcCamera c{};
    c.position = F4(eye);
    c.forward = F4(forward);
    c.right = F4(right);
    c.up = F4(glm::cross(right, forward));
    c.tanHalfFovY = std::tan(glm::radians(fovYDegrees) * 0.5f);
    c.tanHalfFovX = c.tanHalfFovY * float(width) / float(height);
    c.width = c.windowWidth = width;
    c.height = c.windowHeight = height;
    return c;
}

// Every ray in one leaf, moving forward along the leaf's face, its 5D point in that face's frame
// inside the leaf's node, and its hit the brute-force one.
void ExpectValid(const scene::Scene& s, const Hierarchy& h, const LeafBatch& batch,
                 const std::vector<Ray>& rays) {
    // The rays in `missed` reach nothing: ExpectSameHits checks them against brute force.
    ExpectEveryRayOnce(batch, uint32_t(rays.size()));
    for (const RcLeaf& leaf : batch.leaves) {
        const Box5& box = h.Nodes()[leaf.node].box;
        const int face = int(leaf.face), a = FaceAxis(face);
        for (uint32_t j = 0; j < leaf.rayCount; ++j) {
            const uint32_t id = batch.rayIndex[leaf.rayBegin + j];
            const glm::vec3 o = rays[id].origin, d = rays[id].direction;
            const float da = FaceSign(face) * d[a];
            ASSERT_GT(da, 0.0f) << "ray " << id;
            const std::array<float, kDims> p = {FaceX(face, o), o[(a + 1) % 3], o[(a + 2) % 3],
                                                d[(a + 1) % 3] / da, d[(a + 2) % 3] / da};
            ASSERT_TRUE(box.Contains(p)) << "ray " << id << " leaf node " << leaf.node;
        }
    }
    ExpectSameHits(Query(s, batch, rays), BruteForce(s, rays));
}

TEST(Pinhole, RaysLandOnceInsideTheirLeafAndHitAsBruteForce) {
    const scene::Scene s = RandomScene(61, 500, 12, 4);
    // Along an axis; diagonal across three faces; 150 degrees wide, looking down, where the
    // image's corners lie far outside the centre's face (rectangles split before taking one);
    // outside the scene's box, looking at it and looking away (no ray reaches the box).
    const RcCamera cameras[] = {
        MakeCamera({-0.9f, 0.1f, 0.2f}, {1, 0, 0}, {0, 1, 0}, 60.0f, 64, 48),
        MakeCamera({0.1f, -0.2f, 0.3f}, {1, 1, 1}, {0, 1, 0}, 100.0f, 71, 53),
        MakeCamera({0.0f, 0.9f, 0.0f}, {0.1f, -1, 0.05f}, {1, 0, 0}, 150.0f, 90, 45),
        MakeCamera({-2.4f, 0.5f, -1.9f}, {1, -0.2f, 0.8f}, {0, 1, 0}, 70.0f, 64, 48),
        MakeCamera({-2.4f, 0.5f, -1.9f}, {-1, 0, 0}, {0, 1, 0}, 40.0f, 32, 24),
    };
    int nSplitAcrossFaces = 0;
    uint64_t nMissed[std::size(cameras)] = {};
    for (const RcCamera& c : cameras) {
        const uint32_t pixels = c.width * c.height;
        // The whole image, rows cut at both ends, part of one row.
        const uint32_t batches[][2] = {
            {0, pixels}, {3 * c.width + 5, 7 * c.width + 11}, {10 * c.width + 2, 5}};
        for (const auto& [first, n] : batches) {
            const std::vector<Ray> rays = CameraRays(c, first, n);
            for (const Params& p : {DeepParams(s), Params::ForScene(s)}) {
                Hierarchy h(s, p);
                LeafBatch batch;
                ASSERT_TRUE(h.ClassifyPinhole(c, first, n, batch));
                SCOPED_TRACE(testing::Message()
                             << "camera fov " << c.tanHalfFovY << " batch " << first << " + " << n);
                ExpectValid(s, h, batch, rays);
                nMissed[&c - cameras] += batch.missed.size();
                // Looking away from the box: every ray is answered without a leaf.
                if (&c == &cameras[4]) {
                    EXPECT_EQ(batch.missed.size(), n);
                }
                bool faces[kFaceCount] = {};
                for (const RcLeaf& leaf : batch.leaves) faces[leaf.face] = true;
                nSplitAcrossFaces +=
                    faces[0] + faces[1] + faces[2] + faces[3] + faces[4] + faces[5] > 1;
            }
        }
    }
    EXPECT_GE(nSplitAcrossFaces, 4);
    // Looking at the box from outside, some rays pass it.
    EXPECT_GT(nMissed[3], 0u);
}

TEST(Pinhole, AWindowClassifiesTheWholeImagesRaysOfItsPixels) {
    const scene::Scene s = RandomScene(64, 500, 12, 4);
    // Inside the box, and outside it looking at it (some rays pass the box).
    for (RcCamera c :
         {MakeCamera({-0.9f, 0.1f, 0.2f}, {1, 0, 0}, {0, 1, 0}, 60.0f, 64, 48),
          MakeCamera({-2.4f, 0.5f, -1.9f}, {1, -0.2f, 0.8f}, {0, 1, 0}, 70.0f, 64, 48)}) {
        const std::vector<Ray> whole = CameraRays(c, 0, c.width * c.height);
        c.windowX = 13;
        c.windowY = 7;
        c.windowWidth = 35;
        c.windowHeight = 33;
        const uint32_t n = c.windowWidth * c.windowHeight;
        const std::vector<Ray> rays = CameraRays(c, 0, n);
        for (uint32_t i = 0; i < n; ++i) {
            const Ray& w =
                whole[(c.windowY + i / c.windowWidth) * c.width + c.windowX + i % c.windowWidth];
            ASSERT_EQ(rays[i].direction, w.direction) << "window pixel " << i;
        }
        Hierarchy h(s, DeepParams(s));
        LeafBatch batch;
        ASSERT_TRUE(h.ClassifyPinhole(c, 0, n, batch));
        ExpectValid(s, h, batch, rays);
        // A window reaching past the image is refused.
        c.windowX = c.width - c.windowWidth + 1;
        EXPECT_FALSE(h.ClassifyPinhole(c, 0, n, batch));
    }
}

TEST(Pinhole, ThreadCountDoesNotChangeTheResult) {
    const scene::Scene s = RandomScene(62, 400, 5, 2);
    const RcCamera c = MakeCamera({0.2f, 0.1f, -0.8f}, {0.3f, 0.2f, 1}, {0, 1, 0}, 90.0f, 400, 300);
    LeafBatch out[3];
    for (int t = 1; t <= 3; ++t) {
        Params p = DeepParams(s);
        p.threads = uint32_t(t);
        Hierarchy h(s, p);
        ASSERT_TRUE(h.ClassifyPinhole(c, 0, c.width * c.height, out[t - 1]));
    }
    ASSERT_GT(out[0].leaves.size(), 100u);
    for (int t = 1; t < 3; ++t) {
        ASSERT_EQ(out[t].leaves.size(), out[0].leaves.size());
        EXPECT_EQ(out[t].rayIndex, out[0].rayIndex);
        for (size_t l = 0; l < out[0].leaves.size(); ++l) {
            const RcLeaf &a = out[0].leaves[l], &b = out[t].leaves[l];
            ASSERT_EQ(a.rayBegin, b.rayBegin);
            ASSERT_EQ(a.rayCount, b.rayCount);
            ASSERT_EQ(a.candCount, b.candCount);
            ASSERT_EQ(a.face, b.face);
            for (uint32_t k = 0; k < a.candCount; ++k) {
                ASSERT_EQ(out[0].candidates[a.candBegin + k].prim,
                          out[t].candidates[b.candBegin + k].prim);
            }
        }
    }
}

TEST(Pinhole, ListsAreAsShortAsRayByRay) {
    // The rectangles' beams are the rays' tight bounds up to the padding: their lists should be
    // no longer on average than the ray-by-ray classification's.
    const scene::Scene s = RandomScene(63, 2000, 0, 0);
    const RcCamera c = MakeCamera({-0.95f, 0.0f, 0.0f}, {1, 0, 0}, {0, 1, 0}, 60.0f, 320, 240);
    const uint32_t n = c.width * c.height;
    const std::vector<Ray> rays = CameraRays(c, 0, n);
    auto perRay = [](const LeafBatch& b) {
        double sum = 0.0;
        for (const RcLeaf& leaf : b.leaves) sum += double(leaf.candCount) * leaf.rayCount;
        return sum / double(b.nRays);
    };
    Hierarchy h(s, Params::ForScene(s));
    LeafBatch pinhole;
    ASSERT_TRUE(h.ClassifyPinhole(c, 0, n, pinhole));
    h.Reset();
    const LeafBatch byRay = h.Classify(rays);
    EXPECT_LE(perRay(pinhole), 1.1 * perRay(byRay));
    EXPECT_GT(perRay(pinhole), 0.0);
}

TEST(Pinhole, RefusedFarFromTheSceneBoxOrWithRaysInserted) {
    const scene::Scene s = RandomScene(64, 100, 0, 0);
    Hierarchy h(s, Params::ForScene(s));
    LeafBatch batch;
    batch.nRays = 7;
    // More than three times the box's size outside it on x.
    const float far = h.SceneBox().lo.x - 3.01f * h.SceneBox().Size().x;
    const RcCamera outside = MakeCamera({far, 0.0f, 0.0f}, {1, 0, 0}, {0, 1, 0}, 60.0f, 16, 12);
    EXPECT_FALSE(h.ClassifyPinhole(outside, 0, 16 * 12, batch));
    EXPECT_EQ(batch.nRays, 7u);
    const RcCamera inside = MakeCamera({0.0f, 0.0f, 0.0f}, {1, 0, 0}, {0, 1, 0}, 60.0f, 16, 12);
    EXPECT_FALSE(h.ClassifyPinhole(inside, 0, 16 * 12 + 1, batch));  // beyond the image
    const std::vector<Ray> rays = CameraRays(inside, 0, 10);
    h.Insert(rays);
    EXPECT_FALSE(h.ClassifyPinhole(inside, 0, 16 * 12, batch));
    EXPECT_EQ(batch.nRays, 7u);
    h.Subdivide(batch);
    EXPECT_TRUE(h.ClassifyPinhole(inside, 0, 16 * 12, batch));
    EXPECT_EQ(batch.nRays, 16u * 12u);
}

}  // namespace
}  // namespace rayclass::classify
