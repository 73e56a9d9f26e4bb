// The Embree 3 peer of scripts/bench and scripts/yardstick: the rays raybench saved (same
// cameras, same secondary rays from the same hits) shot through Embree with 1 and 2 application
// threads, through each of Embree's APIs at its best:
//   single    rtcIntersect1 / rtcOccluded1, one ray per call;
//   packet16  rtcIntersect16 / rtcOccluded16 over 16 consecutive rays;
//   stream    rtcIntersect1M / rtcOccluded1M over blocks of consecutive rays.
// Before the clock every set is laid out for the API in 4x4 pixel-tile order (eye rays: one
// packet is one tile; a secondary ray takes its pixel's place, so a packet holds the rays of
// neighbouring pixels): structure-of-arrays for the packets, Embree's own RTCRayHit records for
// the stream. Inside the clock each call's rays are copied into Embree's ray records (the calls
// overwrite them) and the hits (distance, global primitive id, geometric normal) or the
// occlusion flags are written out, as rayclass's queries write theirs. The rays are traced in
// Embree's coherent mode (RTC_INTERSECT_CONTEXT_FLAG_COHERENT), without which coherent packets
// run several times slower, except diffuse rays (--coherent on|off overrides).
// Spheres and quadrics are Embree user geometry running rayclass's float routines.
// CSV on stdout, one row per ray kind x API x thread count:
//   kind,api,threads,rays,median_s,min_s,max_s,mrays_s,hits,build_s
// Usage: embree_bench SCENE RAYS.bin [--runs N] [--warmup N] [--threads 1,2]
//                     [--apis single,packet16,stream] [--kinds eye,...] [--coherent auto|on|off]
#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <map>
#include <numeric>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "embree_scene.h"
#include "rayclass/scene/loader.h"
#include "raysets.h"

using namespace rayclass;
using Clock = std::chrono::steady_clock;

namespace {

constexpr size_t kChunk = 4096;       // rays a thread takes at a time (a multiple of 16)
constexpr size_t kStreamBlock = 256;  // rays per rtcIntersect1M call

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

// The order that puts each 4x4 block of pixels together, blocks row by row.
std::vector<size_t> TileOrder(const std::vector<uint32_t>& pixels, uint32_t width) {
    const uint32_t tilesX = (width + 3) / 4;
    auto key = [&](uint32_t p) {
        const uint32_t x = p % width, y = p / width;
        return (uint64_t(y / 4) * tilesX + x / 4) * 16 + (y % 4) * 4 + x % 4;
    };
    std::vector<size_t> order(pixels.size());
    std::iota(order.begin(), order.end(), size_t(0));
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return key(pixels[a]) < key(pixels[b]); });
    return order;
}

// One kind's rays in tile order, padded to a multiple of 16 with invalid lanes.
struct Layout {
    size_t n = 0, padded = 0;
    std::vector<float> ox, oy, oz, dx, dy, dz, tnear, tfar;
    std::vector<RTCRayHit> records;  // the stream API's rays
};

Layout Lay(const std::vector<bench::BenchRay>& rays, const std::vector<size_t>& order) {
    Layout l;
    l.n = rays.size();
    l.padded = (l.n + 15) / 16 * 16;
    for (auto* v : {&l.ox, &l.oy, &l.oz, &l.dx, &l.dy, &l.dz, &l.tnear, &l.tfar}) {
        v->resize(l.padded);
    }
    l.records.resize(l.n);
    for (size_t j = 0; j < l.padded; ++j) {
        const bench::BenchRay& r = rays[order[std::min(j, l.n - 1)]];
        l.ox[j] = r.origin.x, l.oy[j] = r.origin.y, l.oz[j] = r.origin.z;
        l.dx[j] = r.direction.x, l.dy[j] = r.direction.y, l.dz[j] = r.direction.z;
        l.tnear[j] = r.tMin, l.tfar[j] = r.tMax;
        if (j >= l.n) continue;
        RTCRayHit& h = l.records[j];
        h = RTCRayHit{};
        h.ray.org_x = r.origin.x, h.ray.org_y = r.origin.y, h.ray.org_z = r.origin.z;
        h.ray.dir_x = r.direction.x, h.ray.dir_y = r.direction.y, h.ray.dir_z = r.direction.z;
        h.ray.tnear = r.tMin, h.ray.tfar = r.tMax;
        h.ray.mask = 0xFFFFFFFFu;
        h.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        h.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    }
    return l;
}

// What a query writes per ray, in the layout's order.
struct Output {
    std::vector<float> t, ngx, ngy, ngz;
    std::vector<uint32_t> prim;
    std::vector<uint8_t> blocked;

    explicit Output(size_t n) : t(n), ngx(n), ngy(n), ngz(n), prim(n), blocked(n) {}
    void Hit(const bench::EmbreeScene& es, size_t j, float tfar, unsigned geomID, unsigned primID,
             float nx, float ny, float nz) {
        const bool hit = geomID != RTC_INVALID_GEOMETRY_ID;
        t[j] = hit ? tfar : INFINITY;
        prim[j] = hit ? es.GlobalId(geomID, primID) : 0xFFFFFFFFu;
        ngx[j] = nx, ngy[j] = ny, ngz[j] = nz;
    }
    size_t Count(bool shadow, size_t n) const {
        size_t c = 0;
        for (size_t j = 0; j < n; ++j) c += shadow ? blocked[j] != 0 : prim[j] != 0xFFFFFFFFu;
        return c;
    }
};

struct Shot {
    const bench::EmbreeScene& es;
    const Layout& l;
    Output& out;
    bool shadow, coherent;

    RTCIntersectContext Context() const {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        if (coherent) ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        return ctx;
    }

    void Single(size_t b, size_t e) const {
        RTCIntersectContext ctx = Context();
        for (size_t j = b; j < e; ++j) {
            RTCRayHit rh;
            rh.ray.org_x = l.ox[j], rh.ray.org_y = l.oy[j], rh.ray.org_z = l.oz[j];
            rh.ray.dir_x = l.dx[j], rh.ray.dir_y = l.dy[j], rh.ray.dir_z = l.dz[j];
            rh.ray.tnear = l.tnear[j], rh.ray.tfar = l.tfar[j];
            rh.ray.time = 0.0f, rh.ray.mask = 0xFFFFFFFFu, rh.ray.id = 0, rh.ray.flags = 0;
            if (shadow) {
                rtcOccluded1(es.handle(), &ctx, &rh.ray);
                out.blocked[j] = rh.ray.tfar < 0.0f;
            } else {
                rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
                rtcIntersect1(es.handle(), &ctx, &rh);
                out.Hit(es, j, rh.ray.tfar, rh.hit.geomID, rh.hit.primID, rh.hit.Ng_x, rh.hit.Ng_y,
                        rh.hit.Ng_z);
            }
        }
    }

    void Packets(size_t b, size_t e) const {
        RTCIntersectContext ctx = Context();
        for (size_t p = b; p < e; p += 16) {
            alignas(64) int valid[16];
            alignas(64) RTCRayHit16 rh;
            for (int k = 0; k < 16; ++k) {
                const size_t j = p + k;
                valid[k] = j < l.n ? -1 : 0;
                rh.ray.org_x[k] = l.ox[j], rh.ray.org_y[k] = l.oy[j], rh.ray.org_z[k] = l.oz[j];
                rh.ray.dir_x[k] = l.dx[j], rh.ray.dir_y[k] = l.dy[j], rh.ray.dir_z[k] = l.dz[j];
                rh.ray.tnear[k] = l.tnear[j], rh.ray.tfar[k] = l.tfar[j];
                rh.ray.time[k] = 0.0f, rh.ray.mask[k] = 0xFFFFFFFFu;
                rh.ray.id[k] = unsigned(k), rh.ray.flags[k] = 0;
                rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
                rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
            }
            const size_t m = std::min<size_t>(16, l.n - p);
            if (shadow) {
                rtcOccluded16(valid, es.handle(), &ctx, &rh.ray);
                for (size_t k = 0; k < m; ++k) out.blocked[p + k] = rh.ray.tfar[k] < 0.0f;
            } else {
                rtcIntersect16(valid, es.handle(), &ctx, &rh);
                for (size_t k = 0; k < m; ++k) {
                    out.Hit(es, p + k, rh.ray.tfar[k], rh.hit.geomID[k], rh.hit.primID[k],
                            rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]);
                }
            }
        }
    }

    void Stream(size_t b, size_t e) const {
        RTCIntersectContext ctx = Context();
        std::vector<RTCRayHit> work(kStreamBlock);
        for (size_t p = b; p < std::min(e, l.n); p += kStreamBlock) {
            const size_t m = std::min(kStreamBlock, l.n - p);
            std::memcpy(work.data(), l.records.data() + p, m * sizeof(RTCRayHit));
            if (shadow) {
                rtcOccluded1M(es.handle(), &ctx, &work[0].ray, unsigned(m), sizeof(RTCRayHit));
                for (size_t k = 0; k < m; ++k) out.blocked[p + k] = work[k].ray.tfar < 0.0f;
            } else {
                rtcIntersect1M(es.handle(), &ctx, work.data(), unsigned(m), sizeof(RTCRayHit));
                for (size_t k = 0; k < m; ++k) {
                    const RTCRayHit& h = work[k];
                    out.Hit(es, p + k, h.ray.tfar, h.hit.geomID, h.hit.primID, h.hit.Ng_x,
                            h.hit.Ng_y, h.hit.Ng_z);
                }
            }
        }
    }

    void Run(const std::string& api, int threads) const {
        ParallelChunks(l.padded, threads, [&](size_t b, size_t e) {
            if (api == "single")
                Single(b, std::min(e, l.n));
            else if (api == "packet16")
                Packets(b, e);
            else
                Stream(b, e);
        });
    }
};

std::vector<std::string> Split(const std::string& s) {
    std::vector<std::string> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ',')) {
        if (!item.empty()) out.push_back(item);
    }
    return out;
}

struct Args {
    std::string scene, rays, coherent = "auto";
    int runs = 5, warmup = 1;
    std::vector<int> threads{1, 2};
    std::vector<std::string> apis{"single", "packet16", "stream"};
    std::vector<std::string> kinds{std::begin(bench::kKinds), std::end(bench::kKinds)};
};

Args ParseArgs(int argc, char** argv) {
    Args a;
    a.scene = argv[1];
    a.rays = argv[2];
    const std::map<std::string, std::function<void(const std::string&)>> options{
        {"--runs", [&a](const std::string& v) { a.runs = std::max(1, std::stoi(v)); }},
        {"--warmup", [&a](const std::string& v) { a.warmup = std::max(0, std::stoi(v)); }},
        {"--threads",
         [&a](const std::string& v) {
             a.threads.clear();
             for (const auto& t : Split(v)) a.threads.push_back(std::max(1, std::stoi(t)));
         }},
        {"--apis", [&a](const std::string& v) { a.apis = Split(v); }},
        {"--kinds", [&a](const std::string& v) { a.kinds = Split(v); }},
        {"--coherent", [&a](const std::string& v) { a.coherent = v; }}};
    for (int i = 3; i < argc; i += 2) {
        const auto option = options.find(argv[i]);
        if (option == options.end() || i + 1 >= argc) {
            throw std::invalid_argument(std::string("unknown option or missing value: ") + argv[i]);
        }
        option->second(argv[i + 1]);
    }
    for (const auto& api : a.apis) {
        if (api != "single" && api != "packet16" && api != "stream") {
            throw std::invalid_argument("unknown API '" + api + "' (single, packet16, stream)");
        }
    }
    if (a.coherent != "auto" && a.coherent != "on" && a.coherent != "off") {
        throw std::invalid_argument("--coherent takes auto, on or off");
    }
    if (a.threads.empty()) throw std::invalid_argument("--threads needs a count");
    return a;
}

}  // namespace

int main(int argc, char** argv) try {
    if (argc < 3 || argv[1][0] == '-') {
        std::fprintf(stderr,
                     "usage: embree_bench SCENE RAYS.bin [--runs N] [--warmup N] "
                     "[--threads 1,2] [--apis single,packet16,stream] [--kinds LIST] "
                     "[--coherent auto|on|off]\n");
        return 2;
    }
    const Args a = ParseArgs(argc, argv);
    const scene::Scene sc = scene::LoadScene(a.scene);
    const bench::RaySets sets = bench::LoadRaySets(a.rays);
    const int maxThreads = *std::max_element(a.threads.begin(), a.threads.end());
    const bench::EmbreeScene es(sc, maxThreads);
    std::fprintf(stderr, "embree_bench: %u primitives, build %.3f s (%d threads)\n",
                 sc.PrimitiveCount(), es.buildSeconds(), maxThreads);

    std::printf("kind,api,threads,rays,median_s,min_s,max_s,mrays_s,hits,build_s\n");
    for (int k = 0; k < bench::kNumKinds; ++k) {
        const auto& rays = sets.sets[k];
        if (rays.empty() ||
            std::find(a.kinds.begin(), a.kinds.end(), bench::kKinds[k]) == a.kinds.end())
            continue;
        const Layout layout = Lay(rays, TileOrder(sets.pixels[k], sets.width));
        const bool shadow = bench::IsShadowKind(k);
        const bool coherent = a.coherent == "auto" ? std::strcmp(bench::kKinds[k], "diffuse") != 0
                                                   : a.coherent == "on";
        for (const std::string& api : a.apis) {
            for (int threads : a.threads) {
                Output out(layout.padded);
                const Shot shot{es, layout, out, shadow, coherent};
                for (int w = 0; w < a.warmup; ++w) shot.Run(api, threads);
                std::vector<double> times;
                for (int r = 0; r < a.runs; ++r) {
                    const auto t0 = Clock::now();
                    shot.Run(api, threads);
                    times.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
                }
                std::sort(times.begin(), times.end());
                const size_t h = times.size() / 2;
                const double med = times.size() % 2 ? times[h] : 0.5 * (times[h - 1] + times[h]);
                std::printf("%s,%s,%d,%zu,%.6g,%.6g,%.6g,%.4g,%zu,%.4g\n", bench::kKinds[k],
                            api.c_str(), threads, rays.size(), med, times.front(), times.back(),
                            double(rays.size()) / med * 1e-6, out.Count(shadow, layout.n),
                            es.buildSeconds());
                std::fflush(stdout);
            }
        }
    }
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "embree_bench: %s\n", e.what());
    return 1;
}
