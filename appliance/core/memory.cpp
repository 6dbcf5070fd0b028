#include "appliance/core/memory.hpp"

#include "appliance/core/buffer.hpp"

#include <dlfcn.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

#include <malloc.h>

// Under AddressSanitizer malloc is the sanitizer's own allocator and glibc's arenas stay empty
// (mallinfo2 reads 0): heap_usage reads the sanitizer's counters there.
#if defined(__SANITIZE_ADDRESS__)
#define GLINT_ASAN_ALLOCATOR 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define GLINT_ASAN_ALLOCATOR 1
#endif
#endif
#ifdef GLINT_ASAN_ALLOCATOR
// The sanitizer runtime's allocator statistics (clang's <sanitizer/allocator_interface.h>, which
// GCC 12 does not ship).
extern "C" std::size_t __sanitizer_get_current_allocated_bytes();
extern "C" std::size_t __sanitizer_get_heap_size();
#endif

namespace glint {

namespace {

// jemalloc's control interface, found at run time: present only when jemalloc is the allocator.
using Mallctl = int (*)(const char*, void*, std::size_t*, void*, std::size_t);
Mallctl jemalloc_mallctl() {
    static const Mallctl f = reinterpret_cast<Mallctl>(dlsym(RTLD_DEFAULT, "mallctl"));
    return f;
}

long long jemalloc_stat(Mallctl mallctl, const char* name) {
    std::size_t value = 0, size = sizeof value;
    return mallctl(name, &value, &size, nullptr, 0) == 0 ? static_cast<long long>(value) : -1;
}

}  // namespace

void keep_freed_memory() {
    // Blocks up to 32 MiB (glibc's largest allowed threshold on 64-bit) come
    // from the heap and are reused after free; the heap is trimmed only when
    // 1 GiB is free at its top.
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, 1 << 30);
}

void bound_freed_memory() {
    if (jemalloc_mallctl()) return;  // jemalloc returns freed pages itself (its decay); mallopt is glibc's
    mallopt(M_MMAP_THRESHOLD, 1 << 20);  // setting it also fixes it (no dynamic growth)
    mallopt(M_TRIM_THRESHOLD, 8 << 20);
    mallopt(M_ARENA_MAX, 2);
}

bool preload_kiosk_allocator_for_exec() {
#if defined(GLINT_ASAN_ALLOCATOR)
    return false;  // AddressSanitizer replaces malloc itself; a preloaded allocator would break it
#else
    if (jemalloc_mallctl()) return false;  // preloaded already: inherited as it is
    const char* choice = std::getenv("GLINT_KIOSK_ALLOCATOR");
    if (choice && std::strcmp(choice, "glibc") == 0) return false;
    if (access(GLINT_JEMALLOC_PATH, R_OK) != 0) return false;  // not installed: glibc, bound_freed_memory
    // Once only: if the preload does not take (an LD_PRELOAD the loader refuses), the next start
    // of the program goes on with glibc instead of re-executing again.
    if (choice && std::strcmp(choice, "jemalloc-tried") == 0) return false;
    if (setenv("GLINT_KIOSK_ALLOCATOR", "jemalloc-tried", 1) != 0) return false;
    const char* preload = std::getenv("LD_PRELOAD");
    const std::string wanted =
        preload && *preload ? std::string(GLINT_JEMALLOC_PATH) + ":" + preload : std::string(GLINT_JEMALLOC_PATH);
    return setenv("LD_PRELOAD", wanted.c_str(), 1) == 0;
#endif
}

void reexec_with_kiosk_allocator(char** argv) {
    if (!preload_kiosk_allocator_for_exec()) return;
    execv("/proc/self/exe", argv);
    // Still here: run on glibc (bound_freed_memory), only with more growth over the visits.
}

const char* allocator_name() {
#ifdef GLINT_ASAN_ALLOCATOR
    return "asan";
#else
    return jemalloc_mallctl() ? "jemalloc" : "glibc";
#endif
}

HeapUsage heap_usage() {
    HeapUsage u;
#ifdef GLINT_ASAN_ALLOCATOR
    u.in_use_bytes = static_cast<long long>(__sanitizer_get_current_allocated_bytes());
    u.held_bytes = static_cast<long long>(__sanitizer_get_heap_size());
    return u;
#endif
    if (const Mallctl mallctl = jemalloc_mallctl()) {
        // The statistics are a snapshot taken when the epoch advances.
        std::uint64_t epoch = 1;
        std::size_t size = sizeof epoch;
        mallctl("epoch", &epoch, &size, &epoch, size);
        u.in_use_bytes = jemalloc_stat(mallctl, "stats.allocated");
        u.held_bytes = jemalloc_stat(mallctl, "stats.resident");
        return u;
    }
    const struct mallinfo2 m = mallinfo2();
    u.in_use_bytes = static_cast<long long>(m.uordblks + m.hblkhd);
    u.held_bytes = static_cast<long long>(m.arena + m.hblkhd);
    return u;
}

bool return_freed_memory() {
    if (const Mallctl mallctl = jemalloc_mallctl())
        return mallctl("arena.4096.purge", nullptr, nullptr, nullptr, 0) == 0;  // 4096: MALLCTL_ARENAS_ALL
    return malloc_trim(0) != 0;
}

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

HugePageSpan huge_page_span(const void* p, std::size_t bytes) noexcept {
    constexpr std::uintptr_t kHuge = std::uintptr_t(2) << 20;
    if (p == nullptr || bytes < 2 * kHuge) return {};
    // Only whole 2 MiB pages inside the block: madvise wants a page-aligned start, and a huge
    // page that reached past the block would be shared with whatever malloc put beside it.
    const std::uintptr_t begin = (reinterpret_cast<std::uintptr_t>(p) + kHuge - 1) & ~(kHuge - 1);
    const std::uintptr_t end = (reinterpret_cast<std::uintptr_t>(p) + bytes) & ~(kHuge - 1);
    return end > begin ? HugePageSpan{begin, end} : HugePageSpan{};
}

void advise_huge_pages(void* p, std::size_t bytes) noexcept {
    const HugePageSpan span = huge_page_span(p, bytes);
    if (span.end == span.begin) return;
    // Not under jemalloc (the kiosk's allocator): it keeps its address ranges after purging them
    // and reuses them for small slabs, where the advice would outlive the buffer and bring purged
    // memory back 2 MiB at a time (the weeks-long resident creep the soak guards against). glibc
    // maps blocks this large afresh (or, under keep_freed_memory, keeps them in the heap of a
    // short-lived command), so the advice ends with the block or with the process.
    static const bool on_jemalloc = jemalloc_mallctl() != nullptr;
    if (on_jemalloc) return;
    (void)madvise(reinterpret_cast<void*>(span.begin), span.end - span.begin, MADV_HUGEPAGE);
}

}  // namespace glint
