/* Test-only kernel (tests/clrt/layout_test.cpp): the device compiler's view of every struct in
 * rc_types.h. It writes sizeof, alignment and the offset of every field in the order of
 * RC_LAYOUT_ENTRIES (rc_layout.h), the list the test expands on the host; out[0] is the number of
 * values that follow. */
#include "rc_layout.h"

#define RC_PUT(value) out[++n] = (uint)(value);
#define RC_STRUCT(type)  \
    RC_PUT(sizeof(type)) \
    RC_PUT(__alignof__(type))
#define RC_FIELD(type, field) RC_PUT(__builtin_offsetof(type, field))

__kernel void rc_layout_probe(__global uint* out) {
    if (get_global_id(0) != 0) return;
    uint n = 0;
    RC_LAYOUT_ENTRIES(RC_STRUCT, RC_FIELD)
    out[0] = n;
}
