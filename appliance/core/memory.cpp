#include "appliance/core/memory.hpp"

#include <unistd.h>

#include <cstdlib>
#include <string>

#include <malloc.h>

namespace glint {

void keep_freed_memory() {
    // Blocks up to 32 MiB (glibc's largest allowed threshold on 64-bit) come
    // from the heap and are reused after free; the heap is trimmed only when
    // 1 GiB is free at its top.
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, 1 << 30);
}

void bound_freed_memory() {
    mallopt(M_MMAP_THRESHOLD, 1 << 20);  // setting it also fixes it (no dynamic growth)
    mallopt(M_TRIM_THRESHOLD, 8 << 20);
    mallopt(M_ARENA_MAX, 2);
}

bool return_freed_memory() { return malloc_trim(0) != 0; }

void reexec_with_huge_pages(char** argv) {
    constexpr const char* kTunable = "glibc.malloc.hugetlb";
    const char* current = std::getenv("GLIBC_TUNABLES");
    const std::string tunables = current ? current : "";
    if (tunables.find(kTunable) != std::string::npos) return;
    const std::string wanted = tunables.empty() ? std::string(kTunable) + "=1" : tunables + ":" + kTunable + "=1";
    if (setenv("GLIBC_TUNABLES", wanted.c_str(), 1) != 0) return;
    execv("/proc/self/exe", argv);
    // Still here: run as we are (the variable stays set for children, which is harmless).
}

}  // namespace glint
