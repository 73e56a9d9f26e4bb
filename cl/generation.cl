/* The next generation stays on the device: the live secondary slots of a batch (their indices
 * listed by the host in slot order, so the order is deterministic) are copied into the next
 * generation's pages, rays and their info alike. */
#include "rc_types.h"

__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_compact_rays(
    __global const RcRay* secondary, __global const RcRayInfo* secondaryInfo,
    __global const uint* liveSlots, uint liveFirst, uint n, __global RcRay* page,
    __global RcRayInfo* pageInfo, uint pageOffset) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    const uint slot = liveSlots[liveFirst + i];
    page[pageOffset + i] = secondary[slot];
    pageInfo[pageOffset + i] = secondaryInfo[slot];
}
