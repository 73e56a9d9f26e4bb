#include "list_arena.h"

#include <algorithm>

#include "filter.h"

namespace rayclass::classify {

namespace {

// Entries per chunk (a longer list gets a chunk of its own).
constexpr size_t kListChunk = size_t(1) << 18;
// Filtered lists of this many entries or more get a summary of their blocks: the nodes below
// filter them again (a node whose beam keeps most of its list passes it on whole), and their
// filters then skip the blocks their beams cannot reach.
constexpr size_t kSummarisedMin = size_t(1) << 14;

// Room for n entries at the end of `arena`: in its current chunk, else in the next one.
ListOut Take(ListArena& arena, size_t n) {
    if (arena.chunk < arena.chunks.size() && arena.used + n > arena.chunks[arena.chunk].Size()) {
        ++arena.chunk;
        arena.used = 0;
    }
    if (arena.chunk == arena.chunks.size()) arena.chunks.emplace_back();
    FaceList& c = arena.chunks[arena.chunk];
    // Only an empty chunk is too small here, and nothing points into an empty chunk.
    if (c.Size() < arena.used + n) c.Resize(std::max(n, kListChunk));
    return Out(c, arena.used);
}

// The summary of `list`'s blocks, pushed onto `arena`, where it is long enough and the filter
// reads summaries.
void Summarise(ListArena& arena, ListView& list) {
    if (list.n < kSummarisedMin || !FilterSkipsBlocks()) return;
    const size_t n = BlockCount(list.n);
    const ListOut out = Take(arena, n);
    FillBlocks(list, out);
    arena.used += n;
    list.blocks = BlocksOf(out);
}

}  // namespace

size_t ListArena::Bytes() const {
    size_t bytes = 0;
    for (const FaceList& l : chunks) bytes += l.Bytes();
    return bytes;
}

ListView FilterOnto(ListArena& arena, const Bounds6& tight, const ListView& list,
                    uint64_t& boxTests) {
    // No ray of the node gets past X = end, and the list is sorted by near X: cut it there first.
    const float endHi = tight.hi[kDims];
    ListView in = list;
    in.n = CountUpTo(list, endHi);
    const ListOut out = Take(arena, in.n);
    // Every ray's reach is its end minus its start X, so the node's is at most endHi - lo X.
    const float reach = endHi - tight.lo[0];
    const size_t kept = FilterList(MakeBeamTest(*list.frame, tight.ToBox5(), reach), in, out);
    boxTests += in.n;
    arena.used += kept;
    ListView own{out.x0, out.x1, out.y0, out.y1, out.z0, out.z1, out.prim, kept, list.frame};
    Summarise(arena, own);
    return own;
}

bool FilterPairOnto(ListArena& arena, const Bounds6 tight[2], const ListView& list,
                    uint64_t& boxTests, ListView own[2]) {
    const float endHi = tight[0].hi[kDims];
    if (tight[1].hi[kDims] != endHi) return false;
    ListView in = list;
    in.n = CountUpTo(list, endHi);
    // Room for the whole list for the first beam's entries, then the second's.
    ListOut out[2];
    out[0] = Take(arena, in.n);
    arena.used += in.n;
    out[1] = Take(arena, in.n);
    BeamTest t[2];
    for (int j = 0; j < 2; ++j)
        t[j] = MakeBeamTest(*list.frame, tight[j].ToBox5(), endHi - tight[j].lo[0]);
    size_t kept[2];
    FilterPair(t, in, out, kept);
    boxTests += 2 * in.n;
    arena.used += kept[1];
    for (int j = 0; j < 2; ++j) {
        own[j] = {out[j].x0, out[j].x1,   out[j].y0, out[j].y1, out[j].z0,
                  out[j].z1, out[j].prim, kept[j],   list.frame};
        Summarise(arena, own[j]);
    }
    return true;
}

}  // namespace rayclass::classify
