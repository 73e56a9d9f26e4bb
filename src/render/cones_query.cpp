#include "rayclass/render/cones_query.h"

#include <algorithm>
#include <chrono>
#include <mutex>
#include <numeric>

#include "ray_counters.h"
#include "rayclass/accel/cones.h"
#include "rayclass/clrt/mapped.h"
#include "rayclass/render/launch.h"

namespace rayclass::render {

namespace {

using Clock = std::chrono::steady_clock;

constexpr uint32_t kAll = 0xFFFFFFFFu;  // RC_CONES_ALL

// The most survivor ids one level's lists may hold; tiles or groups beyond it test every
// primitive, which bounds the memory incoherent rays need.
constexpr uint64_t kMaxListEntries = uint64_t(1) << 25;

// A batch's rays in tile order (sorted[j] = rays[order[j]]).
struct ConeBatch final : PreparedBatch {
    std::vector<uint32_t> order;
    std::vector<RcRay> sorted;
};

uint32_t TilesOf(uint32_t n) { return (n + accel::kConeTileRays - 1) / accel::kConeTileRays; }
uint32_t GroupsOf(uint32_t nTiles) {
    return (nTiles + accel::kConeGroupTiles - 1) / accel::kConeGroupTiles;
}

// cl/cones.cl's rc_cones_build: the cones of the tiles and groups of the n rays in tile order in
// `sorted`, into `tiles` and `groups`.
void LaunchBuild(clrt::Context& ctx, cl::Kernel& build, const cl::Buffer& sorted, uint32_t n,
                 double margin, const cl::Buffer& tiles, const cl::Buffer& groups,
                 KernelTimer& timer) {
    const uint32_t nTiles = TilesOf(n);
    if (nTiles == 0) return;
    SetArgs(build, sorted, n, nTiles, float(margin), tiles, groups);
    Launch(ctx, build, GroupsOf(nTiles), timer);
}

std::vector<RcCone> ReadCones(clrt::Context& ctx, const cl::Buffer& buffer, uint32_t count) {
    std::vector<RcCone> cones(count);
    if (count == 0) return cones;
    clrt::Check("clEnqueueReadBuffer", [&] {
        ctx.queue().enqueueReadBuffer(buffer, CL_TRUE, 0, count * sizeof(RcCone), cones.data());
    });
    return cones;
}

class ConesQuery final : public RayQuery {
  public:
    ConesQuery(clrt::Context& ctx, const cl::Program& program, const SceneBuffers& scene,
               const scene::Scene& hostScene)
        : ctx_(ctx),
          scene_(scene),
          box_(hostScene.Bounds()),
          margin_(1e-5 * std::max(1e-20f, box_.Diagonal())),
          build_(program, "rc_cones_build"),
          cullGroups_(program, "rc_cones_cull_groups"),
          cullTiles_(program, "rc_cones_cull_tiles"),
          intersect_(program, "rc_intersect_cones"),
          occluded_(program, "rc_occluded_cones") {
        const accel::PrimitiveSpheres s = accel::BoundingSpheres(hostScene, float(margin_));
        // Patch boxes count among the quadric records (AnalyticRecords), so every primitive
        // takes part in the culling.
        nPrims_ =
            scene.hostParams.nTriangles + scene.hostParams.nSpheres + scene.hostParams.nQuadrics;
        sx_ = UploadVector(ctx, s.x);
        sy_ = UploadVector(ctx, s.y);
        sz_ = UploadVector(ctx, s.z);
        sr_ = UploadVector(ctx, s.r);
        for (const char* key : {"cones_rays", "cones_tiles", "cones_groups", "cones_unbounded",
                                "cones_sphere_tests", "cones_candidates", "cones_culled"}) {
            stats_.accel[key] = 0.0;
        }
    }

    std::string Name() const override { return "cones"; }

    QueryStats Stats() const override {
        std::lock_guard<std::mutex> lock(mutex_);
        QueryStats s = stats_;
        const double pairs = s.accel["cones_tiles"] * nPrims_;
        s.accel["cones_culled"] = pairs > 0 ? 1.0 - s.accel["cones_candidates"] / pairs : 0.0;
        s.accel["cones_host_seconds"] = s.hostSeconds;
        return s;
    }

    std::unique_ptr<PreparedBatch> Prepare(const cl::Buffer& rays, uint32_t n,
                                           const cl::CommandQueue& queue,
                                           const RaySource&) override {
        clrt::MappedRead<RcRay> mapped(queue, rays, n);
        auto batch = Build({mapped.data(), n});
        mapped.Unmap();
        clrt::Check("clFinish", [&] { queue.finish(); });
        return batch;
    }

    QueryResult Intersect(const cl::Buffer& rays, uint32_t n, const PreparedBatch* prepared,
                          const cl::Buffer& hits, const ShadeBuffers&,
                          KernelTimer& timer) override {
        if (n == 0) return {0, false};
        const auto* batch = dynamic_cast<const ConeBatch*>(prepared);
        std::unique_ptr<ConeBatch> own;
        if (!batch) {
            // Called without Prepare (raybench, tests): the rays are read here.
            std::vector<RcRay> host(n);
            clrt::Check("clEnqueueReadBuffer", [&] {
                ctx_.queue().enqueueReadBuffer(rays, CL_TRUE, 0, n * sizeof(RcRay), host.data());
            });
            own = Build(host);
            batch = own.get();
        }
        return {Run(intersect_, n, *batch, hits, timer), false};
    }

    uint64_t Occluded(const cl::Buffer&, std::span<const RcRay> hostRays, const cl::Buffer& blocked,
                      KernelTimer& timer) override {
        if (hostRays.empty()) return 0;
        const auto batch = Build(hostRays);
        return Run(occluded_, uint32_t(hostRays.size()), *batch, blocked, timer);
    }

  private:
    std::unique_ptr<ConeBatch> Build(std::span<const RcRay> rays) {
        const auto t0 = Clock::now();
        auto b = std::make_unique<ConeBatch>();
        if (accel::CoherentAsGiven(rays)) {
            b->order.resize(rays.size());
            std::iota(b->order.begin(), b->order.end(), 0u);
        } else {
            b->order = accel::CoherentOrder(rays, box_);
        }
        // The rays in tile order once, so that the kernels read them in place.
        b->sorted.resize(rays.size());
        for (size_t j = 0; j < rays.size(); ++j) b->sorted[j] = rays[b->order[j]];
        std::lock_guard<std::mutex> lock(mutex_);
        stats_.hostSeconds += std::chrono::duration<double>(Clock::now() - t0).count();
        return b;
    }

    // Offsets of each list from the counts; lists past kMaxListEntries become kAll.
    static std::vector<uint32_t> Offsets(const std::vector<uint32_t>& counts) {
        std::vector<uint32_t> offsets(counts.size());
        uint64_t total = 0;
        for (size_t i = 0; i < counts.size(); ++i) {
            const bool fits = total + counts[i] <= kMaxListEntries;
            offsets[i] = fits ? uint32_t(total) : kAll;
            if (fits) total += counts[i];
        }
        return offsets;
    }

    // One level's cull: counts, offsets, then the lists. Returns the offsets (kAll: every
    // primitive) and leaves the counts in `counts`.
    template <typename... Args>
    std::vector<uint32_t> Cull(cl::Kernel& kernel, uint32_t nCones, GrowingBuffer& countsBuf,
                               GrowingBuffer& offsetsBuf, GrowingBuffer& listBuf,
                               std::vector<uint32_t>& counts, KernelTimer& timer,
                               const Args&... args) {
        const cl::Buffer& countsDev = countsBuf.Reserve(ctx_, nCones * sizeof(uint32_t));
        const cl::Buffer& offsetsDev0 = offsetsBuf.Reserve(ctx_, nCones * sizeof(uint32_t));
        const cl::Buffer& list0 = listBuf.Reserve(ctx_, sizeof(uint32_t));
        SetArgs(kernel, args..., sx_, sy_, sz_, sr_, nPrims_, 0u, offsetsDev0, countsDev, list0);
        Launch(ctx_, kernel, nCones, timer);
        counts.resize(nCones);
        clrt::Check("clEnqueueReadBuffer", [&] {
            ctx_.queue().enqueueReadBuffer(countsDev, CL_TRUE, 0, nCones * sizeof(uint32_t),
                                           counts.data());
        });
        std::vector<uint32_t> offsets = Offsets(counts);
        uint64_t total = 0;
        for (size_t i = 0; i < counts.size(); ++i) total += offsets[i] == kAll ? 0 : counts[i];
        const cl::Buffer& offsetsDev = offsetsBuf.Upload(ctx_, offsets);
        const cl::Buffer& list = listBuf.Reserve(ctx_, std::max<uint64_t>(1, total) * 4);
        SetArgs(kernel, args..., sx_, sy_, sz_, sr_, nPrims_, 1u, offsetsDev, countsDev, list);
        Launch(ctx_, kernel, nCones, timer);
        return offsets;
    }

    uint64_t Run(cl::Kernel& kernel, uint32_t n, const ConeBatch& b, const cl::Buffer& out,
                 KernelTimer& timer) {
        const uint32_t nTiles = TilesOf(n), nGroups = GroupsOf(nTiles);
        const cl::Buffer& sorted = sorted_.Share(ctx_, b.sorted);
        const cl::Buffer& tileCones = tileCones_.Reserve(ctx_, nTiles * sizeof(RcCone));
        const cl::Buffer& groupCones = groupCones_.Reserve(ctx_, nGroups * sizeof(RcCone));
        LaunchBuild(ctx_, build_, sorted, n, margin_, tileCones, groupCones, timer);
        std::vector<uint32_t> groupCounts, tileCounts;
        const std::vector<uint32_t> groupOffsets =
            Cull(cullGroups_, nGroups, groupCounts_, groupOffsets_, groupList_, groupCounts, timer,
                 groupCones, nGroups);
        const std::vector<uint32_t> tileOffsets =
            Cull(cullTiles_, nTiles, tileCounts_, tileOffsets_, tileList_, tileCounts, timer,
                 tileCones, nTiles, groupOffsets_.Reserve(ctx_, 0), groupCounts_.Reserve(ctx_, 0),
                 groupList_.Reserve(ctx_, 0));
        const cl::Buffer& order = order_.Upload(ctx_, b.order);
        SetArgs(kernel, sorted, n, order, tileOffsets_.Reserve(ctx_, 0),
                tileCounts_.Reserve(ctx_, 0), tileList_.Reserve(ctx_, 0), scene_.triangles,
                scene_.spheres, scene_.quadrics, scene_.params, out, counters_.Reserve(ctx_, n));
        Launch(ctx_, kernel, PacketItems(n), timer);
        const CounterSums sums = counters_.Sum(ctx_, n);
        Count(n, ReadCones(ctx_, tileCones, nTiles), ReadCones(ctx_, groupCones, nGroups),
              groupCounts, groupOffsets, tileCounts, tileOffsets);
        return sums.tests;
    }

    void Count(uint32_t n, const std::vector<RcCone>& tiles, const std::vector<RcCone>& groups,
               const std::vector<uint32_t>& groupCounts, const std::vector<uint32_t>& groupOffsets,
               const std::vector<uint32_t>& tileCounts, const std::vector<uint32_t>& tileOffsets) {
        double sphereTests = double(groups.size()) * nPrims_, candidates = 0, unbounded = 0;
        for (size_t t = 0; t < tiles.size(); ++t) {
            const size_t g = t / accel::kConeGroupTiles;
            sphereTests += groupOffsets[g] == kAll ? nPrims_ : groupCounts[g];
            candidates += tileOffsets[t] == kAll ? nPrims_ : tileCounts[t];
            unbounded += tiles[t].apex.w < 0.0f;
        }
        for (const RcCone& c : groups) unbounded += c.apex.w < 0.0f;
        std::lock_guard<std::mutex> lock(mutex_);
        stats_.accel["cones_rays"] += n;
        stats_.accel["cones_tiles"] += double(tiles.size());
        stats_.accel["cones_groups"] += double(groups.size());
        stats_.accel["cones_unbounded"] += unbounded;
        stats_.accel["cones_sphere_tests"] += sphereTests;
        stats_.accel["cones_candidates"] += candidates;
    }

    clrt::Context& ctx_;
    const SceneBuffers& scene_;
    Bounds3f box_;
    double margin_;
    uint32_t nPrims_ = 0;
    cl::Buffer sx_, sy_, sz_, sr_;
    cl::Kernel build_, cullGroups_, cullTiles_, intersect_, occluded_;
    GrowingBuffer groupCones_, tileCones_, order_, sorted_;
    GrowingBuffer groupCounts_, groupOffsets_, groupList_, tileCounts_, tileOffsets_, tileList_;
    RayCounters counters_;
    mutable std::mutex mutex_;
    QueryStats stats_;
};

}  // namespace

ConeLevels BuildCones(clrt::Context& ctx, const cl::Program& program, std::span<const RcRay> sorted,
                      double margin) {
    const std::vector<RcRay> rays(sorted.begin(), sorted.end());
    const uint32_t n = uint32_t(rays.size()), nTiles = TilesOf(n), nGroups = GroupsOf(nTiles);
    const cl::Buffer raysDev = UploadVector(ctx, rays);
    const cl::Buffer tiles = DeviceBuffer(ctx, std::max<size_t>(1, nTiles) * sizeof(RcCone));
    const cl::Buffer groups = DeviceBuffer(ctx, std::max<size_t>(1, nGroups) * sizeof(RcCone));
    cl::Kernel build(program, "rc_cones_build");
    KernelTimer timer;
    LaunchBuild(ctx, build, raysDev, n, margin, tiles, groups, timer);
    return {ReadCones(ctx, tiles, nTiles), ReadCones(ctx, groups, nGroups)};
}

std::unique_ptr<RayQuery> MakeConesQuery(clrt::Context& ctx, const cl::Program& program,
                                         const SceneBuffers& buffers, const scene::Scene& scene) {
    return std::make_unique<ConesQuery>(ctx, program, buffers, scene);
}

}  // namespace rayclass::render
