#include "rayclass/classify/stats.h"

#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <string>

#include "rayclass/classify/query.h"

namespace rayclass::classify {

namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double>(b - a).count();
}

// CPU time of the calling thread: unlike the wall clock it does not count time the thread spent
// preempted, which on these shared 2-core machines is most of the noise.
double ThreadCpuSeconds() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

}  // namespace

size_t PeakRssBytes() {
    std::ifstream status("/proc/self/status");
    std::string line;
    while (std::getline(status, line)) {
        if (line.rfind("VmHWM:", 0) == 0) return size_t(std::stoull(line.substr(6))) * 1024;
    }
    return 0;
}

RcCamera AnchorCamera(const scene::Scene& scene, uint32_t width, uint32_t height) {
    const Bounds3f box = scene.Bounds();
    const glm::vec3 eye = box.Center() - glm::vec3(0.25f * box.Size().x, 0.0f, 0.0f);
    RcCamera c{};
    c.position = {eye.x, eye.y, eye.z, 0.0f};
    c.forward = {1.0f, 0.0f, 0.0f, 0.0f};
    c.right = {0.0f, 0.0f, 1.0f, 0.0f};
    c.up = {0.0f, 1.0f, 0.0f, 0.0f};
    c.tanHalfFovY = std::tan(glm::radians(60.0f) * 0.5f);
    c.tanHalfFovX = c.tanHalfFovY * float(width) / float(height);
    c.width = c.windowWidth = width;
    c.height = c.windowHeight = height;
    return c;
}

std::vector<Ray> CameraRays(const RcCamera& c, uint32_t first, uint32_t n) {
    auto vec = [](const rc_float4& v) { return glm::vec3(v.x, v.y, v.z); };
    std::vector<Ray> rays;
    rays.reserve(n);
    for (uint32_t p = first; p < first + n; ++p) {
        const uint32_t x = c.windowX + p % c.windowWidth, y = c.windowY + p / c.windowWidth;
        const float sx = (2.0f * (float(x) + 0.5f) / float(c.width) - 1.0f) * c.tanHalfFovX;
        const float sy = (1.0f - 2.0f * (float(y) + 0.5f) / float(c.height)) * c.tanHalfFovY;
        Ray r;
        r.origin = vec(c.position);
        r.direction = glm::normalize(vec(c.forward) + sx * vec(c.right) + sy * vec(c.up));
        rays.push_back(r);
    }
    return rays;
}

std::vector<Ray> AnchorEyeRays(const scene::Scene& scene, uint32_t width, uint32_t height) {
    return CameraRays(AnchorCamera(scene, width, height), 0, width * height);
}

std::vector<Ray> MirrorRays(const scene::Scene& scene, std::span<const Ray> rays,
                            std::span<const geometry::Hit<float>> hits) {
    const float offset = 1e-4f * scene.Bounds().Diagonal();
    std::vector<Ray> out;
    for (size_t i = 0; i < rays.size(); ++i) {
        if (!hits[i].Valid()) continue;
        const Ray& r = rays[i];
        const glm::vec3 p = r.origin + hits[i].t * r.direction;
        glm::vec3 n = geometry::GeometricNormal(scene, hits[i].prim, p);
        if (!(glm::length(n) > 0.0f)) continue;
        n = glm::normalize(n);
        if (glm::dot(n, r.direction) > 0.0f) n = -n;
        Ray m;
        m.origin = p + offset * n;
        m.direction = glm::normalize(r.direction - 2.0f * glm::dot(r.direction, n) * n);
        out.push_back(m);
    }
    return out;
}

std::vector<Ray> ShadowRays(std::span<const Ray> rays, std::span<const geometry::Hit<float>> hits,
                            const glm::vec3& light, float tMin) {
    std::vector<Ray> out;
    for (size_t i = 0; i < rays.size(); ++i) {
        if (!hits[i].Valid()) continue;
        const Ray& r = rays[i];
        const glm::vec3 p = r.origin + hits[i].t * r.direction;
        const glm::vec3 toLight = light - p;
        const float dist = glm::length(toLight);
        if (!(dist > 0.0f)) continue;
        Ray s;
        s.origin = p;
        s.direction = toLight / dist;
        s.tMin = tMin;
        s.tMax = dist;
        out.push_back(s);
    }
    return out;
}

glm::vec3 AnchorLight(const scene::Scene& scene, float f) {
    const Bounds3f box = scene.Bounds();
    return box.Center() + glm::vec3(0.0f, f * box.Size().y, 0.0f);
}

ClassifyStats ComputeStats(const scene::Scene& scene, std::span<const Ray> rays,
                           const Params& params, int repeats, std::span<geometry::Hit<float>> hits,
                           bool anyHit, const RcCamera* pinhole) {
    ClassifyStats s;
    s.classifiedFromCamera = pinhole != nullptr;
    s.nRays = uint32_t(rays.size());
    s.bruteForceTests = scene.PrimitiveCount();
    const auto t0 = Clock::now();
    Hierarchy h(scene, params);
    s.setupMs = 1e3 * Seconds(t0, Clock::now());

    std::vector<double> times, cpuTimes;
    LeafBatch batch;
    for (int r = 0; r < std::max(repeats, 1); ++r) {
        // A fresh hierarchy each time, but the batch's arrays are reused, as a renderer would.
        h.Reset();
        const auto a = Clock::now();
        const double c = ThreadCpuSeconds();
        // A refusal does not depend on the repeat: the first one decides.
        if (s.classifiedFromCamera) {
            s.classifiedFromCamera = h.ClassifyPinhole(*pinhole, 0, uint32_t(rays.size()), batch);
        }
        if (!s.classifiedFromCamera) {
            h.Classify(rays, batch, anyHit ? RayUse::kAnyHit : RayUse::kNearestHit);
        }
        cpuTimes.push_back(ThreadCpuSeconds() - c);
        times.push_back(Seconds(a, Clock::now()));
    }
    std::nth_element(times.begin(), times.begin() + times.size() / 2, times.end());
    std::nth_element(cpuTimes.begin(), cpuTimes.begin() + cpuTimes.size() / 2, cpuTimes.end());
    const double n = std::max<double>(s.nRays, 1.0);
    s.classifyNsPerRay = 1e9 * times[times.size() / 2] / n;
    s.classifyCpuNsPerRay = 1e9 * cpuTimes[cpuTimes.size() / 2] / n;

    s.nMissed = uint32_t(batch.missed.size());
    s.nLeaves = uint32_t(batch.leaves.size());
    s.nNodes = uint32_t(h.Nodes().size());
    s.maxDepth = h.Counters().maxDepth;
    s.boxTestsPerRay = double(h.Counters().boxTests) / n;
    s.rayMovesPerRay = double(h.Counters().rayMoves) / n;
    double candSum = 0.0;
    for (const RcLeaf& leaf : batch.leaves) {
        candSum += double(leaf.candCount) * leaf.rayCount;
        s.maxCandidates = std::max(s.maxCandidates, leaf.candCount);
    }
    const double nClassified = std::max<double>(s.nRays - s.nMissed, 1.0);
    s.avgCandidates = candSum / nClassified;

    std::vector<geometry::Hit<float>> own;
    if (hits.empty()) {
        own.resize(rays.size());
        hits = own;
    }
    const auto q = Clock::now();
    const uint64_t tests = QueryHost(scene, batch, rays, hits, anyHit);
    s.queryNsPerRay = 1e9 * Seconds(q, Clock::now()) / n;
    s.testsPerRay = double(tests) / n;

    s.hierarchyBytes = h.MemoryBytes();
    // The lists count by size: their capacity beyond it is room reserved for the next
    // generation, untouched unless an earlier generation wrote it.
    s.leafBytes =
        batch.leaves.capacity() * sizeof(RcLeaf) + batch.rayIndex.capacity() * sizeof(rc_uint) +
        batch.candidates.size() * sizeof(RcCandidate) + batch.missed.capacity() * sizeof(rc_uint);
    s.peakRssBytes = PeakRssBytes();
    return s;
}

}  // namespace rayclass::classify
