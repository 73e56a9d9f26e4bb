#include <malloc.h>

#include "rayclass/cli/cli.h"
#include "rayclass/clrt/context.h"

int main(int argc, char** argv) {
    // glibc gives each block above a threshold (128 KiB, rising to the largest such block freed,
    // at most 32 MiB) a mapping of its own, unmapped when freed, and hands the heap's free top
    // beyond 128 KiB back to the system: each stage of a render (the scene's load, the
    // classification's and the BVH's set-up, the batches) then faulted in fresh pages for arrays
    // the size of those the stage before it had freed. Fixed thresholds keep freed blocks for the
    // next stage; a render is one process that ends with its frames.
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, 1 << 30);
    // Before the device thread starts: the scene loads beside it, and setenv there would race.
    rayclass::clrt::PinPoclWorkers();
    return rayclass::cli::Main(argc, argv);
}
