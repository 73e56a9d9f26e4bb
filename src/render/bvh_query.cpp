#include "rayclass/render/bvh_query.h"

#include <algorithm>
#include <numeric>

namespace rayclass::render {

namespace {

constexpr size_t kLocalSize = 64;

template <typename T>
cl::Buffer Upload(clrt::Context& ctx, const std::vector<T>& v) {
    const size_t bytes = std::max<size_t>(1, v.size()) * sizeof(T);
    std::vector<T> one(1);
    return clrt::Check("clCreateBuffer", [&] {
        return cl::Buffer(ctx.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bytes,
                          v.empty() ? one.data() : const_cast<T*>(v.data()));
    });
}

class BvhQuery final : public RayQuery {
public:
    BvhQuery(clrt::Context& ctx, const cl::Program& program, const SceneBuffers& scene,
             const bvh::Bvh& tree)
        : ctx_(ctx),
          scene_(scene),
          nodes_(Upload(ctx, tree.nodes)),
          primIndex_(Upload(ctx, tree.primIndex)),
          intersect_(program, "rc_intersect_bvh"),
          occluded_(program, "rc_occluded_bvh") {}

    std::string Name() const override { return "bvh"; }

    QueryResult Intersect(const cl::Buffer& rays, uint32_t n, const PreparedBatch*,
                          const cl::Buffer& hits, const ShadeBuffers&,
                          KernelTimer& timer) override {
        Run(intersect_, rays, n, hits, timer);
        return {SumTests(n), false};
    }

    uint64_t Occluded(const cl::Buffer& shadowRays, std::span<const RcShadowRay> hostRays,
                      const cl::Buffer& blocked, KernelTimer& timer) override {
        const uint32_t n = uint32_t(hostRays.size());
        Run(occluded_, shadowRays, n, blocked, timer);
        return SumTests(n);
    }

private:
    void Run(cl::Kernel& kernel, const cl::Buffer& rays, uint32_t n, const cl::Buffer& out,
             KernelTimer& timer) {
        if (n == 0) return;
        if (testsCapacity_ < n) {
            testsCapacity_ = n;
            testsBuffer_ = clrt::Check("clCreateBuffer", [&] {
                return cl::Buffer(ctx_.context(), CL_MEM_READ_WRITE, n * sizeof(uint32_t));
            });
        }
        clrt::Check("clSetKernelArg(bvh)", [&] {
            cl_uint i = 0;
            kernel.setArg(i++, rays);
            kernel.setArg(i++, n);
            kernel.setArg(i++, nodes_);
            kernel.setArg(i++, primIndex_);
            kernel.setArg(i++, scene_.triangles);
            kernel.setArg(i++, scene_.spheres);
            kernel.setArg(i++, scene_.quadrics);
            kernel.setArg(i++, scene_.params);
            kernel.setArg(i++, out);
            kernel.setArg(i++, testsBuffer_);
        });
        cl::Event event;
        clrt::Check("clEnqueueNDRangeKernel", [&] {
            ctx_.queue().enqueueNDRangeKernel(kernel, cl::NullRange,
                                              cl::NDRange(clrt::RoundUp(n, kLocalSize)),
                                              cl::NDRange(kLocalSize), nullptr, &event);
        });
        timer.Record(kernel.getInfo<CL_KERNEL_FUNCTION_NAME>(), event);
    }

    uint64_t SumTests(uint32_t n) {
        if (n == 0) return 0;
        tests_.resize(n);
        clrt::Check("clEnqueueReadBuffer", [&] {
            ctx_.queue().enqueueReadBuffer(testsBuffer_, CL_TRUE, 0, n * sizeof(uint32_t),
                                           tests_.data());
        });
        return std::accumulate(tests_.begin(), tests_.end(), uint64_t(0));
    }

    clrt::Context& ctx_;
    const SceneBuffers& scene_;
    cl::Buffer nodes_, primIndex_;
    cl::Kernel intersect_, occluded_;
    cl::Buffer testsBuffer_;
    uint32_t testsCapacity_ = 0;
    std::vector<uint32_t> tests_;
};

}  // namespace

std::unique_ptr<RayQuery> MakeBvhQuery(clrt::Context& ctx, const cl::Program& program,
                                       const SceneBuffers& buffers, const scene::Scene& scene,
                                       const bvh::BuildParams& params) {
    return std::make_unique<BvhQuery>(ctx, program, buffers, bvh::Build(scene, params));
}

}  // namespace rayclass::render
