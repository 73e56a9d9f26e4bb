#include "ray_subdivision.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>

#include "convert.h"
#include "filter.h"
#include "partition.h"


namespace rayclass::classify {

// A thread's share of the generation's conversion: a run of one inserted array.
struct ConvertPiece {
    RayView rays;
    const CommonEnds* ends;
    uint32_t firstId;
    uint64_t fromEnd = 0;
    uint32_t start[kFaceCount], next[kFaceCount];
    Bounds6 bounds[kFaceCount];
    HeldCoords held;
    std::vector<rc_uint> missed;
};

namespace {

// Plans for fewer rays move them on one thread.
constexpr uint32_t kParallelPlanRays = 131072;

// The union of bounds cell[lo, hi).
Bounds6 Union(const Bounds6* cell, int lo, int hi) {
    Bounds6 b = EmptyBounds();
    for (int c = lo; c < hi; ++c) Merge(b, cell[c]);
    return b;
}

// The generation's arrays in `threads` pieces each. Face f's rays go to the slab [f n, (f + 1) n),
// where a piece writes from its first ray's id on: room for all of its rays, so no pass is needed
// to count the faces first.
std::vector<ConvertPiece> MakePieces(const Generation& gen, int threads) {
    std::vector<ConvertPiece> pieces;
    uint32_t firstId = 0;
    for (const auto& [rays, ends] : gen.inserted) {
        // Pieces start at multiples of 16 rays: the conversion places the rays its slow path maps
        // after the others of their run of 16, so the runs must not depend on the thread count.
        const size_t step = (rays.size() + size_t(threads) * 16 - 1) / (size_t(threads) * 16) * 16;
        for (size_t at = 0; at < rays.size(); at += step) {
            ConvertPiece& p = pieces.emplace_back();
            p.rays = rays.Sub(at, std::min(step, rays.size() - at));
            p.ends = &ends;
            p.firstId = firstId + uint32_t(at);
            for (int f = 0; f < kFaceCount; ++f) p.start[f] = p.next[f] = f * gen.n + p.firstId;
        }
        firstId += uint32_t(rays.size());
    }
    return pieces;
}

// Moves the pieces' runs of face f down to follow each other in its slab (from faceBegin), in
// array `a`.
template <typename T>
void CloseUpRuns(const std::vector<ConvertPiece>& pieces, int f, uint32_t faceBegin, T* a) {
    uint32_t to = faceBegin;
    for (const ConvertPiece& p : pieces) {
        const uint32_t len = p.next[f] - p.start[f];
        // Runs only move down: the runs before one hold at most their pieces' rays, so a forward
        // copy never overwrites what it has still to read.
        if (to != p.start[f]) std::copy_n(a + p.start[f], len, a + to);
        to += len;
    }
}

}  // namespace

void RaySubdivision::Classify(const Generation& gen, LeafBatch& out) {
    uint32_t begin[kFaceCount], end[kFaceCount];
    Bounds6 faceBounds[kFaceCount];
    ConvertAll(gen, begin, end, faceBounds, out);
    uint32_t n = 0;
    for (int f = 0; f < kFaceCount; ++f) {
        rayShift_[f] = n - begin[f];
        n += end[f] - begin[f];
    }
    // rayIndex is resized, not cleared (and candidates regrown in Join): every slot is written
    // again, and filling them with zeros first would cost a pass on one thread.
    out.rayIndex.resize(n);
    rayOut_ = out.rayIndex.data();
    FindConstants(faceBounds);
    WorkerPool& pool = core_.pool;
    const int threads = pool.Start(n, pool.TaskCut(n), out);
    if (scratch_.size() < size_t(threads)) scratch_.resize(size_t(threads));
    for (Scratch& s : scratch_) s.plans.clear();
    for (int f = 0; f < kFaceCount; ++f) {
        if (begin[f] == end[f]) continue;
        const NodeRays root{begin[f], end[f],  0, faceBounds[f], core_.faceLists->Whole(f),
                            false,    PlanAt()};
        pool.Queue(begin[f], [this, f, root](Worker& w) { Process(w, uint32_t(f), root); });
    }
    pool.Run(threads);
    pool.Join(out, threads);
    rayOut_ = nullptr;
    // The ray buffers by the rays they hold (two ping-pong buffers and the routing
    // destinations): their face slabs reserve kFaceCount times as much address space, of which
    // only the pages rays are written to are touched.
    size_t scratch = size_t(n) * (2 * (kCoords + 1) + 1) * 4;
    for (const Scratch& s : scratch_) scratch += s.keys.capacity() * 4;
    pool.Finish(scratch, core_.counters);
}

void RaySubdivision::ConvertAll(const Generation& gen, uint32_t* faceBegin, uint32_t* faceEnd,
                                Bounds6* faceBounds, LeafBatch& out) {
    for (int f = 0; f < kFaceCount; ++f) faceBounds[f] = EmptyBounds();
    const uint32_t n = gen.n;
    for (int f = 0; f < kFaceCount; ++f) faceBegin[f] = faceEnd[f] = f * n;
    if (core_.sceneBox.Empty()) {
        for (uint32_t i = 0; i < n; ++i) out.missed.push_back(i);
        return;
    }
    // The pieces map their rays straight into the structure-of-arrays buffer in one pass over
    // them, and their runs are then moved down to follow each other: faces in their slabs, pieces
    // in order within a face. The slabs are address space: only the pages rays are written to are
    // ever touched.
    const int threads = core_.pool.Threads(n);
    std::vector<ConvertPiece> pieces = MakePieces(gen, threads);
    const size_t slabs = size_t(kFaceCount) * n;
    for (int b = 0; b < 2; ++b) {
        for (auto& c : coord_[b]) Regrow(c, slabs);
        Regrow(id_[b], slabs);
    }
    Regrow(dest_, slabs);
    FaceSlabs to{{}, id_[0].data()};
    for (int k = 0; k < kCoords; ++k) to.coord[k] = coord_[0][k].data();
    OnThreads(threads, [&](int t) {
        for (size_t i = size_t(t); i < pieces.size(); i += size_t(threads)) {
            ConvertPiece& p = pieces[i];
            for (auto& b : p.bounds) b = EmptyBounds();
            p.fromEnd = ConvertRays(p.rays, *p.ends, core_.sceneBox, p.firstId, to, p.next,
                                    p.bounds, p.held, p.missed);
        }
    });
    bool moves = false;
    for (int f = 0; f < kFaceCount; ++f) {
        for (const ConvertPiece& p : pieces) {
            moves = moves || (p.next[f] > p.start[f] && p.start[f] != faceEnd[f]);
            faceEnd[f] += p.next[f] - p.start[f];
            Merge(faceBounds[f], p.bounds[f]);
        }
    }
    ReleaseHeld(pieces, faceBounds);
    if (moves) CloseUpFaces(pieces, faceBegin, faceBounds, threads);
    for (ConvertPiece& p : pieces) {
        out.missed.insert(out.missed.end(), p.missed.begin(), p.missed.end());
        core_.counters.fromEnd += p.fromEnd;
    }
    // The pieces come in id order and so do their misses: usually nothing is left to sort.
    if (!std::is_sorted(out.missed.begin(), out.missed.end()))
        std::sort(out.missed.begin(), out.missed.end());
}

void RaySubdivision::ReleaseHeld(const std::vector<ConvertPiece>& pieces,
                                 const Bounds6* faceBounds) {
    // A coordinate a piece held that varies over the face after all (pieces agreed on different
    // values) is read from now on: it gets its value.
    for (int f = 0; f < kFaceCount; ++f) {
        for (const ConvertPiece& p : pieces) {
            for (int k = 0; k < kCoords; ++k) {
                if (((p.held.mask[f] >> k) & 1u) && Varies(faceBounds[f], k))
                    std::fill_n(coord_[0][k].data() + p.start[f], p.next[f] - p.start[f],
                                p.held.value[f][k]);
            }
        }
    }
}

void RaySubdivision::CloseUpFaces(const std::vector<ConvertPiece>& pieces,
                                  const uint32_t* faceBegin, const Bounds6* faceBounds,
                                  int threads) {
    // Each face's arrays apart (the coordinates and the ids), spread over the threads.
    constexpr int kArrays = kCoords + 1;
    OnThreads(threads, [&](int t) {
        for (int job = t; job < kFaceCount * kArrays; job += threads) {
            const int f = job / kArrays, k = job % kArrays;
            if (k == kCoords) {
                CloseUpRuns(pieces, f, faceBegin[f], id_[0].data());
            } else if (Varies(faceBounds[f], k)) {
                CloseUpRuns(pieces, f, faceBegin[f], coord_[0][k].data());
            }
        }
    });
}

void RaySubdivision::FindConstants(const Bounds6* faceBounds) {
    // Coordinates that do not vary among a face's rays (the origin of eye rays, the end of
    // unbounded rays) are never moved.
    for (int f = 0; f < kFaceCount; ++f) {
        for (int k = 0; k < kCoords; ++k) {
            active_[f][k] = Varies(faceBounds[f], k);
            constant_[f][k] = faceBounds[f].lo[k];
        }
    }
}

void RaySubdivision::Process(Worker& w, uint32_t node, const NodeRays& r) {
    // The lists this node filters onto the stack are released when its subtree is built.
    const ArenaMark release(w.stack);
    if (!w.At(node).IsLeaf()) {
        ProcessSplit(w, node, r);
        return;
    }
    const int depth = w.At(node).depth;
    const int face = w.At(node).face;
    // A node with many rays builds its first child and queues the others.
    const bool spawns = r.end - r.begin > core_.pool.Cut();
    // A long list that the node's beam would barely shorten (estimated on a sample) is not
    // copied: the children filter it instead. Near the roots of wide generations (mirror rays)
    // filters keep almost everything, and copying lists of 100k+ boxes is what costs there.
    const bool filtered = !r.reuseList && !KeepsMost(r.tight, r.list);
    ListView own = filtered ? w.Filter(r.tight, r.list, spawns) : CutAtEnd(r.tight, r.list);
    Split split{r.begin, r.buf, true};
    Bounds6 childBox[2];  // left, right
    PlanAt childAt[2];
    if (!SplitRays(w, w.At(node), r, own, split, childBox, childAt)) {
        if (!filtered) own = w.Filter(r.tight, r.list, false);
        EmitLeaf(w, node, r, own);
        return;
    }
    // near: the child whose rays come first, in [begin, mid); the other one's are [mid, end).
    const int near = split.leftFirst ? 0 : 1;
    const bool reuse = filtered && (depth + 1) % std::max(core_.params.splitsPerList, 1) != 0;
    auto child = [&](int side) {
        const bool first = side == near;
        return NodeRays{first ? r.begin : split.mid,
                        first ? split.mid : r.end,
                        split.buf,
                        childBox[side],
                        own,
                        reuse,
                        childAt[side]};
    };
    if (spawns) {
        const uint32_t id = w.NewNode(childBox[near].ToBox5(), face, depth + 1, false);
        w.At(node).child[near] = id;
        if (!(node & kLocal)) w.part->relinked.push_back(node);
        // Queued first, so that another thread can start on it at once.
        const Box5 box = childBox[1 - near].ToBox5();
        Spawn(w, node, 1 - near, &box, child(1 - near));
        Process(w, id, child(near));
        return;
    }
    const uint32_t left = w.NewNode(childBox[0].ToBox5(), face, depth + 1, false);
    w.At(node).child[0] = left;
    if (!(node & kLocal)) w.part->relinked.push_back(node);
    const uint32_t right = w.NewNode(childBox[1].ToBox5(), face, depth + 1, false);
    w.At(node).child[1] = right;
    const uint32_t ids[2] = {left, right};
    Process(w, ids[near], child(near));
    Process(w, ids[1 - near], child(1 - near));
}

void RaySubdivision::ProcessSplit(Worker& w, uint32_t node, const NodeRays& r) {
    const int depth = w.At(node).depth;
    const int face = w.At(node).face;
    const int other = r.buf ^ 1;
    const bool spawns = r.end - r.begin > core_.pool.Cut();
    // Its list is filtered as a leaf's would be: not when the beam keeps most of it.
    const ListView own =
        KeepsMost(r.tight, r.list) ? CutAtEnd(r.tight, r.list) : w.Filter(r.tight, r.list, spawns);
    const Box5 box0 = w.At(w.At(node).child[0]).box;
    const Box5 box1 = w.At(w.At(node).child[1]).box;
    uint32_t count[3] = {};
    RouteRays(face, box0, box1, r.buf, r.begin, r.end, count);
    const uint32_t start[3] = {r.begin, r.begin + count[0], r.begin + count[0] + count[1]};
    w.counters.rayMoves += r.end - r.begin;
    // The later groups first, so that the queue gets them at once.
    const int firstGroup = count[0] ? 0 : (count[1] ? 1 : 2);
    for (int g = 2; g >= 0; --g) {
        if (count[g] == 0) continue;
        const uint32_t b = start[g], e = start[g] + count[g];
        const NodeRays group{b, e, other, Bounds(face, other, b, e), own, false, PlanAt()};
        const bool create = g == 2 && w.At(node).remainder == kNoNode;
        if (spawns && g != firstGroup) {
            const Box5 box = w.At(node).box;
            Spawn(w, node, g, create ? &box : nullptr, group);
            continue;
        }
        if (create) {
            const uint32_t rem = w.NewNode(w.At(node).box, face, depth + 1, true);
            w.At(node).remainder = rem;
            if (!(node & kLocal)) w.part->relinked.push_back(node);
        }
        Process(w, Link(w.At(node), g), group);
    }
}

bool RaySubdivision::SplitRays(Worker& w, const Node& node, const NodeRays& r, const ListView& own,
                               Split& split, Bounds6 childBox[2], PlanAt childAt[2]) {
    const int face = node.face;
    int dim = 0;
    const Params& p = core_.params;
    if (!core_.cost.ChooseSplit(node, r.tight, r.end - r.begin, own, p.minCandidates, dim)) {
        return false;
    }
    PlanAt plan = r.plan;
    if (!plan.plan && p.planRays > 0 && r.end - r.begin >= p.planRays &&
        p.splitRule == SplitRule::kMidpoint) {
        const Plan& made = MakePlan(w, face, dim, r);
        plan = {&made, 0, 0, 1 << made.levels};
    }
    if (plan.plan && PlannedSplit(plan, r.begin, r.end, split.mid, childBox, childAt)) {
        split.buf = plan.plan->buf;
    } else {
        childAt[0] = childAt[1] = {};
        const float value = SplitValue(w, dim, r);
        split = Partition(w, face, dim, value, r, childBox[0], childBox[1]);
    }
    return split.mid != r.begin && split.mid != r.end;
}

void RaySubdivision::Spawn(Worker& w, uint32_t node, int field, const Box5* newBox,
                           const NodeRays& rays) {
    core_.pool.Spawn(rays.begin, [&](Part& part) -> TaskBody {
        Node& parent = w.At(node);
        uint32_t root = Link(parent, field);
        if (newBox) {
            // The new root goes into the task's part, so that the task reads it as its own;
            // Join links the parent to it.
            Node n;
            n.box = *newBox;
            n.face = parent.face;
            n.depth = uint8_t(parent.depth + 1);
            n.isRemainder = field == 2 ? 1 : 0;
            part.newRoot = true;
            part.root = n;
            part.linkPart = w.part;
            part.linkNode = node;
            part.linkField = field;
            root = kLocal;
            Link(parent, field) = kPending;
        }
        // The rays' list views a kept list or the face's list: both outlive the task. So does a
        // plan: workers keep theirs until the next generation.
        return [this, root, rays](Worker& worker) { Process(worker, root, rays); };
    });
}

Bounds6 RaySubdivision::Bounds(int face, int buf, uint32_t begin, uint32_t end) const {
    Bounds6 b;
    for (int k = 0; k < kCoords; ++k) {
        if (active_[face][k]) MinMax(coord_[buf][k].data() + begin, end - begin, b.lo[k], b.hi[k]);
    }
    SetConstants(face, b);
    return b;
}

void RaySubdivision::SetConstants(int face, Bounds6& b) const {
    for (int k = 0; k < kCoords; ++k) {
        if (!active_[face][k]) b.lo[k] = b.hi[k] = constant_[face][k];
    }
}

void RaySubdivision::RouteRays(int face, const Box5& box0, const Box5& box1, int buf,
                               uint32_t begin, uint32_t end, uint32_t count[3]) {
    const int other = buf ^ 1;
    const PartitionIo io = Between(coord_[buf], coord_[other], id_[buf], id_[other]);
    GroupRays(io, active_[face], constant_[face], box0, box1, begin, end, dest_.data(), count);
}

float RaySubdivision::SplitValue(Worker& w, int dim, const NodeRays& r) {
    const float lo = r.tight.lo[dim], hi = r.tight.hi[dim];
    if (core_.params.splitRule == SplitRule::kMedian) {
        const float* x = coord_[r.buf][dim].data();
        std::vector<float>& keys = scratch_[size_t(w.index)].keys;
        keys.assign(x + r.begin, x + r.end);
        const auto m = keys.begin() + keys.size() / 2;
        std::nth_element(keys.begin(), m, keys.end());
        return *m > lo ? *m : std::nextafter(lo, kInf);
    }
    return Midpoint(lo, hi);
}

RaySubdivision::Split RaySubdivision::Partition(Worker& w, int face, int dim, float value,
                                                const NodeRays& r, Bounds6& leftBox,
                                                Bounds6& rightBox) {
    const uint32_t begin = r.begin, end = r.end;
    const int buf = r.buf;
    Split split{begin, buf, true};
    uint32_t first = 0;
    bool firstLeft = true;
    if (AlreadySplit(coord_[buf][dim].data(), value, begin, end, &first, &firstLeft)) {
        // Only the children's bounds to find: the same minima and maxima a move would gather.
        split.leftFirst = firstLeft;
        split.mid = begin + first;
        (firstLeft ? leftBox : rightBox) = Bounds(face, buf, begin, split.mid);
        (firstLeft ? rightBox : leftBox) = Bounds(face, buf, split.mid, end);
        return split;
    }
    const int other = buf ^ 1;
    w.counters.rayMoves += end - begin;
    PartitionIo io = Between(coord_[buf], coord_[other], id_[buf], id_[other]);
    io.key = coord_[buf][dim].data();
    int mask = 0;
    for (int k = 0; k < kCoords; ++k) mask |= active_[face][k] ? 1 << k : 0;
    split.mid = PartitionRays(mask, io, value, begin, end, leftBox, rightBox);
    split.buf = other;
    SetConstants(face, leftBox);
    SetConstants(face, rightBox);
    return split;
}

const RaySubdivision::Plan& RaySubdivision::MakePlan(Worker& w, int face, int dim,
                                                     const NodeRays& r) {
    const uint32_t begin = r.begin, end = r.end;
    const int buf = r.buf;
    const Bounds6& tight = r.tight;
    Plan p;
    // The dimensions: the node's own choice, then ChooseSplit's on the halved interval.
    float extent[kDims];
    for (int k = 0; k < kDims; ++k) extent[k] = tight.hi[k] - tight.lo[k];
    for (p.levels = 0; p.levels < kPlanLevels && dim >= 0; ++p.levels) {
        p.dim[p.levels] = dim;
        extent[dim] *= 0.5f;
        dim = core_.cost.SplitDim(face, extent);
    }
    // The values: each plan node splits its part of the interval in the middle.
    Box5 box[(1 << kPlanLevels) - 1];
    box[0] = tight.ToBox5();
    const int nInner = (1 << p.levels) - 1;
    for (int h = 0; h < nInner; ++h) {
        const int level = std::bit_width(unsigned(h + 1)) - 1;
        const int d = p.dim[level];
        p.value[h] = Midpoint(box[h].lo[d], box[h].hi[d]);
        if (2 * h + 2 < nInner) {
            box[2 * h + 1] = box[2 * h + 2] = box[h];
            box[2 * h + 1].hi[d] = box[2 * h + 2].lo[d] = p.value[h];
        }
    }
    p.buf = buf ^ 1;
    // A big node with threads waiting for work (a face's root, before its first split) shares
    // the moves with them.
    int pieces = 1;
    if (end - begin >= kParallelPlanRays) pieces = std::max(1, core_.pool.IdleThreads() + 1);
    BucketRays(Between(coord_[buf], coord_[p.buf], id_[buf], id_[p.buf]), active_[face],
               {p.levels, p.dim, p.value}, begin, end, p.cellBegin, p.cell, pieces);
    for (int c = 0; c < 1 << p.levels; ++c) SetConstants(face, p.cell[c]);
    w.counters.rayMoves += end - begin;
    ++w.counters.plans;
    w.counters.sharedPlans += pieces > 1 ? 1 : 0;
    return scratch_[size_t(w.index)].plans.emplace_back(p);
}

bool RaySubdivision::PlannedSplit(const PlanAt& at, uint32_t begin, uint32_t end, uint32_t& split,
                                  Bounds6 childBox[2], PlanAt childAt[2]) const {
    const Plan& p = *at.plan;
    int lo = at.cellLo, hi = at.cellHi;
    for (int level = at.level; level < p.levels; ++level) {
        const int mid = (lo + hi) / 2;
        if (p.cellBegin[mid] == begin) {
            lo = mid;
        } else if (p.cellBegin[mid] == end) {
            hi = mid;
        } else {
            split = p.cellBegin[mid];
            childBox[0] = Union(p.cell, lo, mid);
            childBox[1] = Union(p.cell, mid, hi);
            const bool last = level + 1 == p.levels;
            childAt[0] = last ? PlanAt{} : PlanAt{&p, level + 1, lo, mid};
            childAt[1] = last ? PlanAt{} : PlanAt{&p, level + 1, mid, hi};
            return true;
        }
    }
    return false;
}

void RaySubdivision::EmitLeaf(Worker& w, uint32_t node, const NodeRays& r, const ListView& list) {
    RcLeaf leaf{};
    // Leaves fill their faces' ranges in order, and the faces follow each other in rayIndex:
    // the ids go straight to their place there, and Join sorts the leaves by it.
    leaf.rayBegin = r.begin + rayShift_[w.At(node).face];
    leaf.rayCount = r.end - r.begin;
    std::copy(id_[r.buf].begin() + r.begin, id_[r.buf].begin() + r.end, rayOut_ + leaf.rayBegin);
    w.PushLeaf(leaf, node, list, r.tight.hi[kDims]);
}
}  // namespace rayclass::classify
