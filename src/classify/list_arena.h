// Where the candidate lists of a generation's nodes live while it is classified: chunks filled
// one after another and kept between generations. A worker uses one arena as a stack (a node's
// list is released when its subtree is built: siblings reuse the memory, which stays in cache)
// and another for the lists that queued tasks read later, released when the generation is done.
// Private to the classify module.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "lists.h"
#include "support.h"

namespace rayclass::classify {

struct ListArena {
    std::vector<FaceList> chunks;
    size_t chunk = 0, used = 0;

    void Clear() { chunk = used = 0; }
    size_t Bytes() const;
};

// Releases, when it goes out of scope, the lists pushed onto `arena` since it was made: a node's
// lists, once its subtree is built.
class ArenaMark {
  public:
    explicit ArenaMark(ListArena& a) : arena_(a), chunk_(a.chunk), used_(a.used) {}
    ArenaMark(const ArenaMark&) = delete;
    ArenaMark& operator=(const ArenaMark&) = delete;
    ~ArenaMark() {
        arena_.chunk = chunk_;
        arena_.used = used_;
    }

  private:
    ListArena& arena_;
    const size_t chunk_, used_;
};

// The entries of `list` that the beam of `tight` may reach, pushed onto `arena`; adds the boxes
// tested to `boxTests`.
ListView FilterOnto(ListArena& arena, const Bounds6& tight, const ListView& list,
                    uint64_t& boxTests);
// FilterOnto for the two beams of a node's halves, in one pass over the list: own[j] for
// tight[j]. False, doing nothing, when their rays end at different X (the list is cut there).
bool FilterPairOnto(ListArena& arena, const Bounds6 tight[2], const ListView& list,
                    uint64_t& boxTests, ListView own[2]);

}  // namespace rayclass::classify
