// The Embree 3 baseline of scripts/bench: the rays raybench saved (same cameras, same secondary
// rays from the same hits) shot through Embree's BVH with 1 and 2 application threads, one ray
// per call (rtcIntersect1/rtcOccluded1) and 16-ray packets of consecutive rays
// (rtcIntersect16/rtcOccluded16), traced in Embree's coherent mode
// (RTC_INTERSECT_CONTEXT_FLAG_COHERENT) except for diffuse rays, as Embree's best figures are
// measured. Without the flag coherent packets run several times slower, which would make Embree
// look slower than it is.
// CSV on stdout, one row per ray kind x API x thread count:
//   kind,api,threads,rays,median_s,min_s,max_s,mrays_s,hits
// Usage: embree_bench SCENE RAYS.bin [--runs N] [--warmup N] [--threads 1,2]
// Triangles only: a scene with spheres or quadrics is refused (exit 3), Embree would not shoot
// the same geometry.
#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "raysets.h"
#include "rayclass/scene/loader.h"

using namespace rayclass;
using Clock = std::chrono::steady_clock;

namespace {

constexpr size_t kChunk = 4096;  // rays a thread takes at a time (a multiple of 16)

// Runs fn(begin, end) over [0, n) in chunks on `threads` threads.
template <typename F>
void ParallelChunks(size_t n, int threads, F&& fn) {
    std::atomic<size_t> next{0};
    auto worker = [&] {
        for (;;) {
            const size_t b = next.fetch_add(kChunk);
            if (b >= n) return;
            fn(b, std::min(n, b + kChunk));
        }
    };
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
    worker();
    for (auto& t : pool) t.join();
}

// Returns the number of rays that hit (or are occluded).
size_t Shoot(RTCScene scene, const std::vector<bench::BenchRay>& rays, bool shadow, bool packet,
             bool coherent, int threads) {
    std::atomic<size_t> hits{0};
    ParallelChunks(rays.size(), threads, [&](size_t b, size_t e) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        if (coherent) ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        size_t local = 0;
        if (!packet) {
            for (size_t i = b; i < e; ++i) {
                const auto& r = rays[i];
                RTCRayHit rh;
                rh.ray.org_x = r.origin.x;
                rh.ray.org_y = r.origin.y;
                rh.ray.org_z = r.origin.z;
                rh.ray.tnear = r.tMin;
                rh.ray.dir_x = r.direction.x;
                rh.ray.dir_y = r.direction.y;
                rh.ray.dir_z = r.direction.z;
                rh.ray.time = 0.0f;
                rh.ray.tfar = r.tMax;
                rh.ray.mask = 0xFFFFFFFFu;
                rh.ray.id = 0;
                rh.ray.flags = 0;
                if (shadow) {
                    rtcOccluded1(scene, &ctx, &rh.ray);
                    local += rh.ray.tfar < 0.0f;
                } else {
                    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
                    rtcIntersect1(scene, &ctx, &rh);
                    local += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
                }
            }
        } else {
            for (size_t p = b; p < e; p += 16) {
                alignas(64) int valid[16];
                alignas(64) RTCRayHit16 rh;
                for (int k = 0; k < 16; ++k) {
                    const size_t i = p + k;
                    valid[k] = i < e ? -1 : 0;
                    const auto& r = rays[std::min(i, e - 1)];
                    rh.ray.org_x[k] = r.origin.x;
                    rh.ray.org_y[k] = r.origin.y;
                    rh.ray.org_z[k] = r.origin.z;
                    rh.ray.tnear[k] = r.tMin;
                    rh.ray.dir_x[k] = r.direction.x;
                    rh.ray.dir_y[k] = r.direction.y;
                    rh.ray.dir_z[k] = r.direction.z;
                    rh.ray.time[k] = 0.0f;
                    rh.ray.tfar[k] = r.tMax;
                    rh.ray.mask[k] = 0xFFFFFFFFu;
                    rh.ray.id[k] = k;
                    rh.ray.flags[k] = 0;
                    rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
                    rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
                }
                if (shadow) {
                    rtcOccluded16(valid, scene, &ctx, &rh.ray);
                    for (int k = 0; k < 16; ++k) local += valid[k] && rh.ray.tfar[k] < 0.0f;
                } else {
                    rtcIntersect16(valid, scene, &ctx, &rh);
                    for (int k = 0; k < 16; ++k)
                        local += valid[k] && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
                }
            }
        }
        hits += local;
    });
    return hits;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: embree_bench SCENE RAYS.bin [--runs N] [--warmup N] "
                             "[--threads 1,2]\n");
        return 2;
    }
    int runs = 5, warmup = 1;
    std::vector<int> threadCounts{1, 2};
    for (int i = 3; i + 1 < argc; i += 2) {
        const std::string a = argv[i], v = argv[i + 1];
        if (a == "--runs") runs = std::max(1, std::stoi(v));
        else if (a == "--warmup") warmup = std::max(0, std::stoi(v));
        else if (a == "--threads") {
            threadCounts.clear();
            size_t pos = 0;
            while (pos <= v.size()) {
                const size_t comma = v.find(',', pos);
                threadCounts.push_back(std::stoi(v.substr(pos, comma - pos)));
                if (comma == std::string::npos) break;
                pos = comma + 1;
            }
        } else {
            std::fprintf(stderr, "embree_bench: unknown option %s\n", a.c_str());
            return 2;
        }
    }
    try {
        const scene::Scene sc = scene::LoadScene(argv[1]);
        if (!sc.spheres.empty() || !sc.quadrics.empty()) {
            std::fprintf(stderr, "embree_bench: %s has spheres or quadrics; triangles only\n",
                         argv[1]);
            return 3;
        }
        const bench::RaySets sets = bench::LoadRaySets(argv[2]);
        const int maxThreads = *std::max_element(threadCounts.begin(), threadCounts.end());
        const std::string config = "threads=" + std::to_string(maxThreads);
        RTCDevice device = rtcNewDevice(config.c_str());
        if (!device) {
            std::fprintf(stderr, "embree_bench: rtcNewDevice failed\n");
            return 1;
        }
        const auto tb = Clock::now();
        RTCScene scene = rtcNewScene(device);
        rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
        RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
            geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
            3 * sc.triangles.size()));
        auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
            geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
            sc.triangles.size()));
        for (size_t t = 0; t < sc.triangles.size(); ++t) {
            for (int k = 0; k < 3; ++k) {
                std::memcpy(v + 9 * t + 3 * k, &sc.triangles[t].p[k], 3 * sizeof(float));
                idx[3 * t + k] = unsigned(3 * t + k);
            }
        }
        rtcCommitGeometry(geom);
        rtcAttachGeometry(scene, geom);
        rtcReleaseGeometry(geom);
        rtcCommitScene(scene);
        const double buildS = std::chrono::duration<double>(Clock::now() - tb).count();
        std::fprintf(stderr, "embree_bench: %zu triangles, build %.3f s (%d threads)\n",
                     sc.triangles.size(), buildS, maxThreads);

        std::printf("kind,api,threads,rays,median_s,min_s,max_s,mrays_s,hits,build_s\n");
        for (int k = 0; k < bench::kNumKinds; ++k) {
            const auto& rays = sets.sets[k];
            if (rays.empty()) continue;
            const bool shadow = bench::IsShadowKind(k);
            const bool coherent = std::strcmp(bench::kKinds[k], "diffuse") != 0;
            for (const bool packet : {false, true}) {
                for (int threads : threadCounts) {
                    size_t hits = 0;
                    for (int w = 0; w < warmup; ++w)
                        hits = Shoot(scene, rays, shadow, packet, packet && coherent, threads);
                    std::vector<double> times;
                    for (int r = 0; r < runs; ++r) {
                        const auto t0 = Clock::now();
                        hits = Shoot(scene, rays, shadow, packet, packet && coherent, threads);
                        times.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
                    }
                    std::sort(times.begin(), times.end());
                    const double med = times.size() % 2
                                           ? times[times.size() / 2]
                                           : 0.5 * (times[times.size() / 2 - 1] + times[times.size() / 2]);
                    std::printf("%s,%s,%d,%zu,%.6g,%.6g,%.6g,%.4g,%zu,%.4g\n", bench::kKinds[k],
                                packet ? "packet16" : "single", threads, rays.size(), med,
                                times.front(), times.back(), double(rays.size()) / med * 1e-6,
                                hits, buildS);
                    std::fflush(stdout);
                }
            }
        }
        rtcReleaseScene(scene);
        rtcReleaseDevice(device);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "embree_bench: %s\n", e.what());
        return 1;
    }
    return 0;
}
