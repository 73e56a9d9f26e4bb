#include "rayclass/render/auto_query.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <limits>
#include <vector>

#include "rayclass/clrt/mapped.h"
#include "rayclass/render/launch.h"

namespace rayclass::render {

namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Seconds the classified query's shading kernel has run on `timer`. The BVH leaves shading to
// the renderer, after its query returns, so this is not the classification's cost.
double ShadingSeconds(const KernelTimer& timer) {
    const auto it = timer.Seconds().find("rc_shade16_ids");
    return it == timer.Seconds().end() ? 0.0 : it->second;
}

class AutoQuery final : public RayQuery {
  public:
    AutoQuery(clrt::Context& ctx, std::unique_ptr<RayQuery> classified,
              std::function<std::unique_ptr<RayQuery>()> makeBvh)
        : ctx_(ctx),
          cpuClock_(CostInProcessCpuTime(ctx.device().getInfo<CL_DEVICE_TYPE>())),
          classified_(std::move(classified)),
          makeBvh_(std::move(makeBvh)) {}

    std::string Name() const override { return "auto"; }
    QueryStats Stats() const override { return classified_->Stats(); }

    void Reset() override {
        classified_->Reset();
        if (bvh_) bvh_->Reset();
    }

    void BeginGeneration(uint32_t generation, const cl::Buffer& rays, uint32_t n,
                         KernelTimer& timer) override {
        classified_->BeginGeneration(generation, rays, n, timer);
        NextGeneration();
        if (!onBvh_) Sample(rays, n, timer);
        MarkReturn();
    }

    void DescribeGeneration(GenerationStats& gen) const override {
        gen.query = (onBvh_ ? bvh_ : classified_)->Name();
        gen.shadowQuery = classified_->Name();
        gen.classifiedNs = costs_.PredictedClassified() * 1e9;
        gen.bvhSampleNs = costs_.bvhSample * 1e9;
    }

    // Runs on the worker thread, while the render thread may be in Intersect or Occluded; its
    // time counts where the render thread waits for it (see Intersect).
    std::unique_ptr<PreparedBatch> Prepare(const cl::Buffer& rays, uint32_t n,
                                           const cl::CommandQueue& queue,
                                           const RaySource& source) override {
        if (onBvh_) return nullptr;  // set before this generation's first Prepare
        return classified_->Prepare(rays, n, queue, source);
    }

    void Recycle(std::unique_ptr<PreparedBatch> batch) override {
        if (batch) classified_->Recycle(std::move(batch));
    }

    // The classification's cost is the cost clock's time over this call and the stretch since the
    // render thread's last call here, where the worker thread prepared the batch (an upper bound:
    // that also holds the render thread's own work between batches). In process CPU time each
    // thread's work counts once where Prepare and this call overlap, and time without a core not
    // at all.
    QueryResult Intersect(const cl::Buffer& rays, uint32_t n, const PreparedBatch* prepared,
                          const cl::Buffer& hits, const ShadeBuffers& shade,
                          KernelTimer& timer) override {
        if (onBvh_) return bvh_->Intersect(rays, n, nullptr, hits, shade, timer);
        const double shading = ShadingSeconds(timer);
        const QueryResult result = classified_->Intersect(rays, n, prepared, hits, shade, timer);
        times_.wall += SecondsSince(lastReturn_);
        times_.cost += CostSeconds() - lastReturnCost_;
        times_.shading += ShadingSeconds(timer) - shading;
        rays_ += n;
        MarkReturn();
        return result;
    }

    uint64_t Occluded(const cl::Buffer& shadowRays, std::span<const RcRay> hostRays,
                      const cl::Buffer& blocked, KernelTimer& timer) override {
        const uint64_t tests = classified_->Occluded(shadowRays, hostRays, blocked, timer);
        MarkReturn();
        return tests;
    }

  private:
    // The last generation's measurements, if the classification answered it, become its cost; a
    // new sample is to be taken.
    void NextGeneration() {
        if (rays_ > 0 && !onBvh_) {
            costs_.classifiedBefore = costs_.classified;
            costs_.classified = times_.QuerySeconds() / double(rays_);
        }
        costs_.bvhSample = 0;
        times_ = {};
        rays_ = 0;
    }

    double CostSeconds() const {
        return cpuClock_ ? ProcessCpuSeconds()
                         : std::chrono::duration<double>(Clock::now().time_since_epoch()).count();
    }

    void MarkReturn() {
        lastReturn_ = Clock::now();
        lastReturnCost_ = CostSeconds();
    }

    // Times the BVH on a sample of the generation's first batch rays[0, n), once the
    // classification has been measured.
    void Sample(const cl::Buffer& rays, uint32_t n, KernelTimer& timer) {
        if (costs_.classified == 0 || n == 0) return;
        Bvh();
        {
            clrt::MappedRead<RcRay> mapped(ctx_.queue(), rays, n);
            samples_ = PickBvhSample(mapped.span());
            mapped.Unmap();
        }
        costs_.bvhSample = TimeSamples(timer);
        onBvh_ = costs_.PreferBvh();
    }

    // Cost-clock seconds per ray of the BVH on its cheapest sample group, each answered once on the
    // otherwise idle device, the first sample's after one run that compiles the kernel and faults
    // in the tree. The cheapest, because the machine's other work only ever adds to a group's time
    // (in process CPU time, through the caches it shares).
    double TimeSamples(KernelTimer& timer) {
        double best = std::numeric_limits<double>::infinity();
        for (const std::vector<RcRay>& group : samples_) {
            const cl::Buffer& rays = sampleRays_.Upload(ctx_, group);
            const uint32_t m = uint32_t(group.size());
            const cl::Buffer& hits = sampleHits_.Reserve(ctx_, m * sizeof(RcHit));
            const auto run = [&] {
                bvh_->Intersect(rays, m, nullptr, hits, ShadeBuffers{}, timer);
                clrt::Check("clFinish", [&] { ctx_.queue().finish(); });
            };
            // The upload, and nothing else.
            clrt::Check("clFinish", [&] { ctx_.queue().finish(); });
            if (!sampled_) run();
            sampled_ = true;
            const double t0 = CostSeconds();
            run();
            best = std::min(best, (CostSeconds() - t0) / double(m));
        }
        return best;
    }

    RayQuery& Bvh() {
        if (!bvh_) bvh_ = makeBvh_();
        return *bvh_;
    }

    clrt::Context& ctx_;
    const bool cpuClock_;  // CostInProcessCpuTime of the device
    std::unique_ptr<RayQuery> classified_, bvh_;
    std::function<std::unique_ptr<RayQuery>()> makeBvh_;
    Clock::time_point lastReturn_;  // when the render thread last returned from this query
    double lastReturnCost_ = 0;     // and the cost clock's seconds then
    bool onBvh_ = false;            // the BVH answers this generation's nearest hits, and the rest
    bool sampled_ = false;          // a sample has run (see TimeSamples)
    QueryCosts costs_;              // what this generation's choice compared
    // The classification's seconds on this generation, and its rays.
    ClassifiedTimes times_;
    uint64_t rays_ = 0;
    std::vector<std::vector<RcRay>> samples_;
    GrowingBuffer sampleRays_, sampleHits_;
};

}  // namespace

double ProcessCpuSeconds() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return double(t.tv_sec) + double(t.tv_nsec) * 1e-9;
}

bool CostInProcessCpuTime(cl_device_type type) { return (type & CL_DEVICE_TYPE_CPU) != 0; }

double ClassifiedTimes::QuerySeconds() const {
    return wall > 0 ? cost * std::max(0.0, 1.0 - shading / wall) : 0.0;
}

std::vector<std::vector<RcRay>> PickBvhSample(std::span<const RcRay> rays) {
    const size_t runs = kSampleGroups * kSampleRuns;
    const size_t runRays = std::min(kSampleRunRays, rays.size() / (runs * kSampleShare));
    if (runRays == 0) return {std::vector<RcRay>(rays.begin(), rays.end())};
    std::vector<std::vector<RcRay>> groups(kSampleGroups);
    const size_t spacing = rays.size() / runs;
    for (size_t r = 0; r < runs; ++r) {
        const auto first = rays.begin() + std::ptrdiff_t(r * spacing);
        groups[r % kSampleGroups].insert(groups[r % kSampleGroups].end(), first,
                                         first + std::ptrdiff_t(runRays));
    }
    return groups;
}

std::unique_ptr<RayQuery> MakeAutoQuery(clrt::Context& ctx, std::unique_ptr<RayQuery> classified,
                                        std::function<std::unique_ptr<RayQuery>()> makeBvh) {
    return std::make_unique<AutoQuery>(ctx, std::move(classified), std::move(makeBvh));
}

}  // namespace rayclass::render
