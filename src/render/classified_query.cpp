#include "rayclass/render/classified_query.h"

#include <chrono>
#include <cstddef>
#include <cstring>
#include <mutex>

#include "rayclass/classify/hierarchy.h"
#include "rayclass/clrt/mapped.h"
#include "rayclass/render/launch.h"

namespace rayclass::render {

namespace {

using Clock = std::chrono::steady_clock;

// A classified batch: the leaves and, per leaf, its rays' slots and its kernel style.
struct ClassifiedBatch final : PreparedBatch {
    classify::LeafBatch batch;
    std::vector<uint32_t> rayLeaf;         // per slot of batch.rayIndex: its leaf (when all
                                           // leaves take one per-ray kernel)
    std::vector<uint32_t> vertexLeaves;    // leaves the vertex-style kernel answers
    std::vector<uint32_t> fragmentLeaves;  // leaves the fragment-style kernel answers
};

// Auto's choice per leaf: the style of less work in units of a fragment packet's test of one
// candidate. A vertex-style leaf costs kVertexIteration per ray and block of 16 candidates
// (chart 1 of docs/bench: at equal tests per ray the vertex style ran several times slower) plus
// Params::vertexGatherCost per block, for rc_gather_blocks's copy of the block's triangles.
// On PoCL on a CPU that copy costs about as much as kCpuGatherCost fragment iterations. Without
// it auto sent millions of blocks of deep mirror generations to the vertex style; with it no leaf
// is cheaper as vertex style (that needs more iterations per block than the 16 candidates a
// block holds), and the render's query, gather and shading kernels ran faster. Other devices
// keep the rule without the gather until measured.
constexpr uint64_t kVertexIteration = 3;
constexpr float kCpuGatherCost = 13.0f;

float GatherCost(const clrt::Context& ctx, const classify::Params& params) {
    return params.vertexGatherCost >= 0.0f ? params.vertexGatherCost
           : ctx.info().type == "cpu"      ? kCpuGatherCost
                                           : 0.0f;
}

// True when a query with `style` may launch the vertex-style kernels. Auto's rule (SortLeaves)
// prefers the fragment style for every leaf once the gather costs at least 16 - kVertexIteration:
// a leaf of r rays then costs at most r + 15 <= kVertexIteration r + gatherCost per block as
// packets.
bool TakesVertex(KernelStyle style, float gatherCost) {
    return style == KernelStyle::kVertex ||
           (style == KernelStyle::kAuto && gatherCost < float(16 - kVertexIteration));
}

// `name`'s kernel in `program` where `needed`, else none: a frame's program holds only the
// kernel files its style launches (ClassifiedKernelFiles).
cl::Kernel KernelIf(bool needed, const cl::Program& program, const char* name) {
    return needed ? cl::Kernel(program, name) : cl::Kernel();
}

class ClassifiedQuery final : public RayQuery {
  public:
    ClassifiedQuery(clrt::Context& ctx, const cl::Program& program, const SceneBuffers& buffers,
                    const scene::Scene& scene, const classify::Params& params, KernelStyle style)
        : ctx_(ctx),
          scene_(buffers),
          hierarchy_(scene, params),
          shadowHierarchy_(hierarchy_),  // a copy: it shares the presorted face lists
          style_(style),
          gatherCost_(GatherCost(ctx, params)),
          queryScalar_(KernelIf(style == KernelStyle::kScalar, program, "rc_query_scalar")),
          occludedScalar_(KernelIf(style == KernelStyle::kScalar, program, "rc_occluded_scalar")),
          gather_(KernelIf(TakesVertex(style, gatherCost_), program, "rc_gather_blocks")),
          queryVertexShade_(
              KernelIf(TakesVertex(style, gatherCost_), program, "rc_query_vertex_shade")),
          occludedVertex_(KernelIf(TakesVertex(style, gatherCost_), program, "rc_occluded_vertex")),
          queryFragment_(program, "rc_query_fragment"),
          occludedFragment_(program, "rc_occluded_fragment"),
          shadeIds_(program, "rc_shade16_ids"),
          writeMisses_(program, "rc_write_misses"),
          edges_(TriangleEdges(ctx, program, buffers, uint32_t(scene.triangles.size()))) {}

    std::string Name() const override {
        return "classify/" + std::string(NameOf(kKernelStyles, style_));
    }
    QueryStats Stats() const override {
        std::lock_guard<std::mutex> lock(mutex_);
        return stats_;
    }

    std::unique_ptr<PreparedBatch> Prepare(const cl::Buffer& rays, uint32_t n,
                                           const cl::CommandQueue& queue,
                                           const RaySource& source) override {
        std::unique_ptr<ClassifiedBatch> out;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            if (!pool_.empty()) {
                out = std::move(pool_.back());
                pool_.pop_back();
            }
        }
        if (!out) out = std::make_unique<ClassifiedBatch>();
        // A camera's eye rays are classified from the camera, unread (several times faster, for
        // lists as long), unless it lies more than three box sizes from the scene.
        if (source.camera) {
            const auto t0 = Clock::now();
            const bool classified =
                hierarchy_.ClassifyPinhole(*source.camera, source.firstPixel, n, out->batch);
            AddHostSeconds(Seconds(t0));
            if (classified) {
                {
                    std::lock_guard<std::mutex> lock(mutex_);
                    stats_.eyeRaysFromCamera += n;
                }
                SortLeaves(*out, style_);
                return out;
            }
        }
        // Classified in place: an RcRay is a classify::Ray, and mapping costs no copy on a
        // device that shares host memory.
        static_assert(sizeof(classify::Ray) == sizeof(RcRay) &&
                      offsetof(classify::Ray, direction) == offsetof(RcRay, direction));
        clrt::MappedRead<RcRay> mapped(queue, rays, n);
        Classify(hierarchy_, classify::RayView(mapped.data(), n, sizeof(RcRay)),
                 classify::RayUse::kNearestHit, *out, style_);
        mapped.Unmap();
        clrt::Check("clFinish", [&] { queue.finish(); });
        return out;
    }

    // Each generation's rays get hierarchies of their own; later batches of the generation land
    // in the remainders of earlier ones. Routing a generation through the splits an earlier one
    // made cost more than rebuilding: those splits fit other rays, and their nodes filtered their
    // lists again for the newcomers: deep mirror renders spend much less host time this way,
    // for a few more intersection tests and the same image. Shadow rays toward a point light are
    // classified from the light, where old and new splits come out the same.
    void BeginGeneration(uint32_t, const cl::Buffer&, uint32_t, KernelTimer&) override { Reset(); }

    void Reset() override {
        hierarchy_.Reset();
        shadowHierarchy_.Reset();
    }

    void Recycle(std::unique_ptr<PreparedBatch> batch) override {
        if (!batch) return;
        std::lock_guard<std::mutex> lock(mutex_);
        pool_.emplace_back(static_cast<ClassifiedBatch*>(batch.release()));
    }

    QueryResult Intersect(const cl::Buffer& rays, uint32_t n, const PreparedBatch* prepared,
                          const cl::Buffer& hits, const ShadeBuffers& shade,
                          KernelTimer& timer) override {
        if (n == 0) return {};
        const auto& batch = static_cast<const ClassifiedBatch&>(*prepared);
        // Every kernel style writes the hit of each ray in a leaf: only the rays that reach
        // nothing need the miss written (none, usually, but for eye rays from a camera outside
        // the scene box: many of Cornell's). A kernel writes theirs: filling the whole buffer
        // instead cost several times raybench's copy time, for kernels as fast within the noise.
        if (!batch.batch.missed.empty()) {
            const auto t0 = Clock::now();
            const cl::Buffer& ids = missedBuf_.Share(ctx_, batch.batch.missed);
            const uint32_t nMissed = uint32_t(batch.batch.missed.size());
            SetArgs(writeMisses_, ids, nMissed, hits);
            AddHostSeconds(Seconds(t0));
            Launch(ctx_, writeMisses_, nMissed, timer);
        }
        return Query(batch, rays, hits, &shade, timer);
    }

    uint64_t Occluded(const cl::Buffer& shadowRays, std::span<const RcRay> hostRays,
                      const cl::Buffer& blocked, KernelTimer& timer) override {
        const uint32_t n = uint32_t(hostRays.size());
        if (n == 0) return 0;
        clrt::Check("clEnqueueFillBuffer",
                    [&] { ctx_.queue().enqueueFillBuffer(blocked, uint8_t(0), 0, n); });
        // Every slot: empty ones have no direction and miss at once.
        Classify(shadowHierarchy_, classify::RayView(hostRays.data(), n, sizeof(RcRay)),
                 classify::RayUse::kAnyHit, shadowBatch_, ShadowStyle());
        const classify::BuildCounters& built = shadowHierarchy_.Counters();
        {
            std::lock_guard<std::mutex> lock(mutex_);
            stats_.shadowRaysFromLight += built.fromEnd;
            stats_.shadowRaysInCells += built.cellsPerSide > 0 ? built.fromEnd : 0;
        }
        return Query(shadowBatch_, shadowRays, blocked, nullptr, timer).tests;
    }

  private:
    // rc_triangle_edges' records of the scene's triangles, which the fragment kernels' loops
    // over a scene of triangles alone read (one record, unread, for a scene without triangles).
    static cl::Buffer TriangleEdges(clrt::Context& ctx, const cl::Program& program,
                                    const SceneBuffers& scene, uint32_t nTriangles) {
        cl::Buffer edges =
            DeviceBuffer(ctx, std::max<size_t>(nTriangles, 1) * 3 * sizeof(rc_float4));
        if (nTriangles == 0) return edges;
        cl::Kernel k(program, "rc_triangle_edges");
        SetArgs(k, scene.triangles, nTriangles, edges);
        KernelTimer timer;
        Launch(ctx, k, nTriangles, timer);
        clrt::Check("clFinish", [&] { ctx.queue().finish(); });
        return edges;
    }

    // Shadow rays' leaves all take one style; auto takes packets. Any-hit queries let each
    // vertex-style ray stop at its first blocker, yet on PoCL lockstep packets were as fast or
    // faster (raybench's shadow-ray query kernels).
    KernelStyle ShadowStyle() const {
        return style_ == KernelStyle::kAuto ? KernelStyle::kFragment : style_;
    }

    // Classifies `rays` into out's leaves and sorts the leaves by kernel style (`style`: the
    // query's, or ShadowStyle() for shadow rays).
    void Classify(classify::Hierarchy& hierarchy, classify::RayView rays, classify::RayUse use,
                  ClassifiedBatch& out, KernelStyle style) {
        const auto t0 = Clock::now();
        hierarchy.Classify(rays, out.batch, use);
        AddHostSeconds(Seconds(t0));
        SortLeaves(out, style);
    }

    // Sorts out's leaves by kernel style (`style`: see Classify).
    void SortLeaves(ClassifiedBatch& out, KernelStyle style) {
        const auto t0 = Clock::now();
        // Leaves lie in ray order and cover every slot, so when one per-ray kernel answers them
        // all, its slots are batch.rayIndex itself and only their leaves are needed.
        const bool perRay = style == KernelStyle::kScalar || style == KernelStyle::kVertex;
        out.rayLeaf.resize(perRay ? out.batch.rayIndex.size() : 0);
        out.vertexLeaves.clear();
        out.fragmentLeaves.clear();
        for (uint32_t l = 0; l < out.batch.leaves.size(); ++l) {
            const RcLeaf& leaf = out.batch.leaves[l];
            if (perRay) std::fill_n(out.rayLeaf.begin() + leaf.rayBegin, leaf.rayCount, l);
            bool fragment = style == KernelStyle::kFragment;
            if (style == KernelStyle::kAuto) {
                const uint64_t packets = (leaf.rayCount + 15) / 16,
                               blocks = (leaf.candCount + 15) / 16;
                fragment =
                    double(packets * leaf.candCount) <=
                    (double(kVertexIteration * leaf.rayCount) + gatherCost_) * double(blocks);
            }
            (fragment ? out.fragmentLeaves : out.vertexLeaves).push_back(l);
        }
        AddHostSeconds(Seconds(t0));
    }

    void AddHostSeconds(double s) {
        std::lock_guard<std::mutex> lock(mutex_);
        stats_.hostSeconds += s;
    }

    // The batch's arrays every kernel style reads. They are not written again before its
    // kernels are done: SumTests waits for the query kernels, the last to read them.
    struct BatchArrays {
        const cl::Buffer &leaves, &rayIndex, &candidates;
    };

    // The slots a vertex-style launch answers and the leaf of each.
    struct VertexSlots {
        const cl::Buffer &slots, &slotLeaf;
        uint32_t n;
    };

    // Nearest hits (shade != nullptr: also shades every ray) or occlusion (shade == nullptr).
    QueryResult Query(const ClassifiedBatch& cb, const cl::Buffer& rays, const cl::Buffer& out,
                      const ShadeBuffers* shade, KernelTimer& timer) {
        const bool shadow = shade == nullptr;
        const auto t0 = Clock::now();
        const BatchArrays arrays{leavesBuf_.Share(ctx_, cb.batch.leaves),
                                 rayIndexBuf_.Share(ctx_, cb.batch.rayIndex),
                                 candidatesBuf_.Share(ctx_, cb.batch.candidates)};
        if (style_ == KernelStyle::kScalar) {
            return {QueryScalar(cb, arrays, rays, out, shadow, t0, timer), false};
        }
        // Every leaf of a shadow batch takes ShadowStyle().
        std::span<const uint32_t> vertexLeaves = cb.vertexLeaves;
        std::span<const uint32_t> fragmentLeaves = cb.fragmentLeaves;
        if (shadow) {
            ListShadowLeaves(cb);
            const bool packets = ShadowStyle() == KernelStyle::kFragment;
            vertexLeaves = packets ? std::span<const uint32_t>() : shadowLeaves_;
            fragmentLeaves = packets ? shadowLeaves_ : std::span<const uint32_t>();
        }
        uint64_t tests = QueryVertex(cb, arrays, vertexLeaves, rays, out, shade, timer);
        if (!fragmentLeaves.empty()) {
            tests += QueryFragment(cb, arrays, fragmentLeaves, rays, out, shadow, timer);
        }
        if (shadow) return {tests, false};
        ShadeUnshaded(cb, rays, out, *shade, timer);
        return {tests, true};
    }

    // The shadow batch's leaves that a kernel visits: those with candidates. A leaf without
    // any blocks none of its rays, whose flags Occluded has already cleared, and its packets
    // would only load rays (whole lights' views of a bare wall or floor on Conference).
    void ListShadowLeaves(const ClassifiedBatch& cb) {
        shadowLeaves_.clear();
        for (uint32_t l = 0; l < cb.batch.leaves.size(); ++l) {
            if (cb.batch.leaves[l].candCount > 0) shadowLeaves_.push_back(l);
        }
    }

    // Every slot by the scalar kernel (host time counted from `t0`).
    uint64_t QueryScalar(const ClassifiedBatch& cb, const BatchArrays& arrays,
                         const cl::Buffer& rays, const cl::Buffer& out, bool shadow,
                         Clock::time_point t0, KernelTimer& timer) {
        const cl::Buffer& rayLeaf = rayLeafBuf_.Upload(ctx_, cb.rayLeaf);
        const uint32_t nSlots = uint32_t(cb.batch.rayIndex.size());
        const cl::Buffer& testsBuf = testsBuf_.Reserve(ctx_, nSlots * sizeof(uint32_t));
        cl::Kernel& k = shadow ? occludedScalar_ : queryScalar_;
        SetArgs(k, rays, arrays.rayIndex, rayLeaf, nSlots, arrays.leaves, arrays.candidates,
                scene_.triangles, scene_.spheres, scene_.quadrics, scene_.params, out, testsBuf);
        AddHostSeconds(Seconds(t0));
        Launch(ctx_, k, nSlots, timer);
        return SumTests(testsBuf, nSlots);
    }

    // Vertex-style leaves: their rays as slots, their candidates as blocks of 16, launched in
    // chunks whose blocks fit one device allocation (incoherent rays can have long lists in many
    // leaves).
    uint64_t QueryVertex(const ClassifiedBatch& cb, const BatchArrays& arrays,
                         std::span<const uint32_t> leaves, const cl::Buffer& rays,
                         const cl::Buffer& out, const ShadeBuffers* shade, KernelTimer& timer) {
        const size_t maxBlocks = std::min<size_t>(ctx_.info().maxAllocBytes, size_t(256) << 20) /
                                 sizeof(RcTriangleBlock16);
        uint64_t tests = 0;
        for (size_t next = 0; next < leaves.size();) {
            const auto t0 = Clock::now();
            const size_t first = next;
            next = ListBlocks(cb, leaves, first, maxBlocks);
            const bool wholeBatch =
                first == 0 && next == cb.batch.leaves.size() && !cb.rayLeaf.empty();
            const VertexSlots slots =
                wholeBatch ? VertexSlots{arrays.rayIndex, rayLeafBuf_.Upload(ctx_, cb.rayLeaf),
                                         uint32_t(cb.batch.rayIndex.size())}
                           : ListSlots(cb, leaves.subspan(first, next - first));
            tests += LaunchVertex(arrays, slots, rays, out, shade, t0, timer);
        }
        return tests;
    }

    // Lists the candidate blocks of leaves[first, end) in blockLeaf_ and blockFirst_, and each
    // leaf's first block in leafFirstBlock_, up to `maxBlocks` blocks (one leaf at least);
    // returns `end`.
    size_t ListBlocks(const ClassifiedBatch& cb, std::span<const uint32_t> leaves, size_t first,
                      size_t maxBlocks) {
        blockLeaf_.clear();
        blockFirst_.clear();
        leafFirstBlock_.assign(cb.batch.leaves.size(), 0);
        size_t next = first;
        for (; next < leaves.size(); ++next) {
            const uint32_t l = leaves[next];
            const RcLeaf& leaf = cb.batch.leaves[l];
            const size_t leafBlocks = (leaf.candCount + 15) / 16;
            if (!blockLeaf_.empty() && blockLeaf_.size() + leafBlocks > maxBlocks) break;
            leafFirstBlock_[l] = uint32_t(blockLeaf_.size());
            for (uint32_t c = 0; c < leaf.candCount; c += 16) {
                blockLeaf_.push_back(l);
                blockFirst_.push_back(c);
            }
        }
        return next;
    }

    // The rays of `leaves` as slots, uploaded with their leaves.
    VertexSlots ListSlots(const ClassifiedBatch& cb, std::span<const uint32_t> leaves) {
        vertexSlots_.clear();
        vertexRayLeaf_.clear();
        for (const uint32_t l : leaves) {
            const RcLeaf& leaf = cb.batch.leaves[l];
            for (uint32_t r = 0; r < leaf.rayCount; ++r) {
                vertexSlots_.push_back(cb.batch.rayIndex[leaf.rayBegin + r]);
                vertexRayLeaf_.push_back(l);
            }
        }
        const cl::Buffer& slots = slotsBuf_.Upload(ctx_, vertexSlots_);
        return {slots, rayLeafBuf_.Upload(ctx_, vertexRayLeaf_), uint32_t(vertexSlots_.size())};
    }

    // The gather of the listed blocks, then the vertex-style kernel over `s` (host time counted
    // from `t0`).
    uint64_t LaunchVertex(const BatchArrays& arrays, const VertexSlots& s, const cl::Buffer& rays,
                          const cl::Buffer& out, const ShadeBuffers* shade, Clock::time_point t0,
                          KernelTimer& timer) {
        const uint32_t nBlocks = uint32_t(blockLeaf_.size());
        const cl::Buffer& blockLeaf = blockLeafBuf_.Upload(ctx_, blockLeaf_);
        const cl::Buffer& blockFirst = blockFirstBuf_.Upload(ctx_, blockFirst_);
        const cl::Buffer& leafFirstBlock = leafFirstBlockBuf_.Upload(ctx_, leafFirstBlock_);
        const cl::Buffer& blocks =
            blocksBuf_.Reserve(ctx_, size_t(nBlocks) * sizeof(RcTriangleBlock16));
        const cl::Buffer& testsBuf = testsBuf_.Reserve(ctx_, s.n * sizeof(uint32_t));
        SetArgs(gather_, blockLeaf, blockFirst, nBlocks, arrays.leaves, arrays.candidates,
                scene_.triangles, scene_.params, blocks);
        cl::Kernel& k = shade ? queryVertexShade_ : occludedVertex_;
        if (!shade) {
            SetArgs(k, rays, s.slots, s.slotLeaf, s.n, arrays.leaves, leafFirstBlock, blocks,
                    scene_.triangles, scene_.spheres, scene_.quadrics, scene_.params, out,
                    testsBuf);
        } else {
            SetArgs(k, rays, shade->rayInfo, s.slots, s.slotLeaf, s.n, arrays.leaves,
                    leafFirstBlock, blocks, out, testsBuf, scene_.triangles, scene_.triangleShading,
                    scene_.spheres, scene_.quadrics, scene_.materials, scene_.lights, scene_.params,
                    shade->radiance, shade->NormalsOut(), shade->shadow.rays,
                    shade->shadow.contribution, shade->secondary.rays, shade->secondary.info,
                    shade->spawned);
        }
        AddHostSeconds(Seconds(t0));
        Launch(ctx_, gather_, nBlocks, timer);
        Launch(ctx_, k, s.n, timer);
        return SumTests(testsBuf, s.n);
    }

    // Fragment-style leaves: packets of 16 of a leaf's rays, in lockstep over its candidates.
    uint64_t QueryFragment(const ClassifiedBatch& cb, const BatchArrays& arrays,
                           std::span<const uint32_t> leaves, const cl::Buffer& rays,
                           const cl::Buffer& out, bool shadow, KernelTimer& timer) {
        const auto t0 = Clock::now();
        // Sized first and written by index: a push_back loop cost measurably more. The arrays
        // stay unchanged until SumTests below has waited for the kernel, so a CPU device reads
        // them in place.
        uint32_t nPackets = 0;
        for (uint32_t l : leaves) nPackets += (cb.batch.leaves[l].rayCount + 15) / 16;
        packetLeaf_.resize(nPackets);
        packetFirst_.resize(nPackets);
        uint32_t* packetLeafAt = packetLeaf_.data();
        uint32_t* packetFirstAt = packetFirst_.data();
        for (uint32_t l : leaves) {
            const uint32_t count = cb.batch.leaves[l].rayCount;
            for (uint32_t r = 0; r < count; r += 16) {
                *packetLeafAt++ = l;
                *packetFirstAt++ = r;
            }
        }
        const cl::Buffer& packetLeaf = packetLeafBuf_.Share(ctx_, packetLeaf_);
        const cl::Buffer& packetFirst = packetFirstBuf_.Share(ctx_, packetFirst_);
        const cl::Buffer& testsBuf = fragmentTestsBuf_.Reserve(ctx_, nPackets * sizeof(uint32_t));
        cl::Kernel& k = shadow ? occludedFragment_ : queryFragment_;
        SetArgs(k, rays, arrays.rayIndex, packetLeaf, packetFirst, nPackets, arrays.leaves,
                arrays.candidates, scene_.triangles, edges_, scene_.spheres, scene_.quadrics,
                scene_.params, out, testsBuf);
        AddHostSeconds(Seconds(t0));
        Launch(ctx_, k, nPackets, timer);
        return SumTests(testsBuf, nPackets);
    }

    // The rays the vertex kernel did not shade (fragment leaves' rays and the misses), in slot
    // order: shading then walks the batch's arrays in order, not leaf by leaf.
    void ListUnshaded(const ClassifiedBatch& cb) {
        const auto t0 = Clock::now();
        unshaded_.clear();
        if (!cb.vertexLeaves.empty()) {
            shadedByVertex_.assign(cb.batch.nRays, 0);
            for (uint32_t l : cb.vertexLeaves) {
                const RcLeaf& leaf = cb.batch.leaves[l];
                for (uint32_t r = 0; r < leaf.rayCount; ++r) {
                    shadedByVertex_[cb.batch.rayIndex[leaf.rayBegin + r]] = 1;
                }
            }
            for (uint32_t i = 0; i < cb.batch.nRays; ++i) {
                if (!shadedByVertex_[i]) unshaded_.push_back(i);
            }
        }
        AddHostSeconds(Seconds(t0));
    }

    // Shades the rays the vertex kernel left, in the thesis's fragment pass 2: 16 rays a
    // work-item in float16 lanes, every light of a ray with it (the lanes are rays, so the
    // thesis's per-(ray, light) pass has nothing left to spread over them).
    void ShadeUnshaded(const ClassifiedBatch& cb, const cl::Buffer& rays, const cl::Buffer& hits,
                       const ShadeBuffers& shade, KernelTimer& timer) {
        ListUnshaded(cb);
        // Without vertex-style leaves every ray is left: the kernel takes a null id list.
        const bool allRays = cb.vertexLeaves.empty();
        if (!allRays && unshaded_.empty()) return;
        const uint32_t nIds = allRays ? cb.batch.nRays : uint32_t(unshaded_.size());
        const cl::Buffer ids = allRays ? cl::Buffer() : unshadedBuf_.Upload(ctx_, unshaded_);
        SetArgs(shadeIds_, rays, shade.rayInfo, hits, ids, nIds, scene_.triangles,
                scene_.triangleShading, scene_.spheres, scene_.quadrics, scene_.materials,
                scene_.lights, scene_.params, shade.radiance, shade.NormalsOut(), shade.shadow.rays,
                shade.shadow.contribution, shade.secondary.rays, shade.secondary.info,
                shade.spawned);
        Launch(ctx_, shadeIds_, PacketItems(nIds), timer);
    }

    static double Seconds(Clock::time_point t0) {
        return std::chrono::duration<double>(Clock::now() - t0).count();
    }

    uint64_t SumTests(const cl::Buffer& buffer, uint32_t n) {
        return SumCounters(ctx_, buffer, n, testsHost_);
    }

    clrt::Context& ctx_;
    const SceneBuffers& scene_;
    // A generation's eye, reflection and refraction rays share one hierarchy (classified on the
    // worker thread); its shadow rays have their own (classified on the calling thread). One
    // thread each: a hierarchy per thread repeats the filtering of the long top-level lists,
    // which cost more than the thread saved.
    classify::Hierarchy hierarchy_;
    classify::Hierarchy shadowHierarchy_;
    KernelStyle style_;
    float gatherCost_;  // auto's price of a vertex-style candidate block (Params)
    cl::Kernel queryScalar_, occludedScalar_, gather_, queryVertexShade_, occludedVertex_,
        queryFragment_, occludedFragment_, shadeIds_, writeMisses_;
    ClassifiedBatch shadowBatch_;
    std::vector<uint32_t> shadowLeaves_, vertexSlots_, vertexRayLeaf_, blockLeaf_, blockFirst_,
        leafFirstBlock_, packetLeaf_, packetFirst_, testsHost_, unshaded_;
    std::vector<uint8_t> shadedByVertex_;
    cl::Buffer edges_;  // TriangleEdges
    GrowingBuffer leavesBuf_, rayIndexBuf_, candidatesBuf_, rayLeafBuf_, testsBuf_, blockLeafBuf_,
        blockFirstBuf_, leafFirstBlockBuf_, slotsBuf_, blocksBuf_, packetLeafBuf_, packetFirstBuf_,
        fragmentTestsBuf_, unshadedBuf_, missedBuf_;
    mutable std::mutex mutex_;  // guards stats_ (Prepare runs on a worker thread) and pool_
    QueryStats stats_;
    std::vector<std::unique_ptr<ClassifiedBatch>> pool_;  // recycled batches
};

}  // namespace

std::unique_ptr<RayQuery> MakeClassifiedQuery(clrt::Context& ctx, const cl::Program& program,
                                              const SceneBuffers& buffers,
                                              const scene::Scene& scene,
                                              const classify::Params& params, KernelStyle style) {
    return std::make_unique<ClassifiedQuery>(ctx, program, buffers, scene, params, style);
}

KernelStyle ClassifiedStyle(const RenderOptions& options) {
    return options.triangleTest == TriangleTest::kWatertight ? KernelStyle::kScalar
                                                             : options.kernel;
}

std::vector<std::string> ClassifiedKernelFiles(const clrt::Context& ctx,
                                               const classify::Params& params, KernelStyle style) {
    std::vector<std::string> files = {"classified.cl"};
    if (TakesVertex(style, GatherCost(ctx, params))) files.push_back("classified_vertex.cl");
    if (style == KernelStyle::kScalar) files.push_back("classified_scalar.cl");
    return files;
}

}  // namespace rayclass::render
