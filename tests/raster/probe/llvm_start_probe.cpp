// LD_PRELOAD probe for one libLLVM shared by two clients in one process (PoCL and Mesa's llvmpipe
// in rayclass): their starts register targets in LLVM's global registry without a lock, so two
// threads inside a start at once can corrupt it. The probe stands in for the X86 target's
// registration, which both starts call, holds each call open long enough that overlapping starts
// are sure to meet inside it, and aborts when they do.
#include <dlfcn.h>
#include <link.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace {

using Fn = void (*)();

std::atomic<int> inside{0};

// The registration in the loaded libLLVM. Not dlsym(RTLD_NEXT): the ICD loader and Mesa open
// their libraries, libLLVM with them, outside the global scope that RTLD_NEXT searches.
Fn RealRegistration() {
    Fn found = nullptr;
    dl_iterate_phdr(
        [](dl_phdr_info* info, size_t, void* out) {
            if (std::strstr(info->dlpi_name, "libLLVM") == nullptr) return 0;
            void* lib = dlopen(info->dlpi_name, RTLD_LAZY | RTLD_NOLOAD);
            if (lib == nullptr) return 0;
            *static_cast<Fn*>(out) = reinterpret_cast<Fn>(dlsym(lib, "LLVMInitializeX86Target"));
            dlclose(lib);
            return *static_cast<Fn*>(out) != nullptr ? 1 : 0;
        },
        &found);
    return found;
}

void Fail(const char* why) {
    std::fprintf(stderr, "llvm_start_probe: %s\n", why);
    std::abort();
}

}  // namespace

extern "C" void LLVMInitializeX86Target() {
    if (inside.fetch_add(1) != 0) Fail("two threads start LLVM at once");
    usleep(300 * 1000);
    const Fn real = RealRegistration();
    if (real == nullptr) Fail("no loaded libLLVM has LLVMInitializeX86Target");
    real();
    inside.fetch_sub(1);
}
