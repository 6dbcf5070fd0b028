// Process-wide memory settings of the appliance's long-running programs.
#pragma once

namespace glint {

// Keeps large freed blocks in the process instead of returning them to the
// kernel. The convolution engine allocates and frees buffers of 1-20 MiB for
// every map (sums, levels, SH tables); with glibc's defaults each comes from a
// fresh mmap and its first touch costs a page fault per 4 KiB (measured: 14 %
// of the auto whole set's wall time). Freed blocks above 32 MiB still go back
// to the kernel, so the largest buffers (maps of 4096x2048 and inputs up to
// 8192x4096) do not stay resident; the rest is a bounded working set.
// Call once at start, before any thread is created.
void keep_freed_memory();

// The kiosk's policy (`glint run`, `glint replay`), the opposite trade: a program that runs for
// weeks must give back what a visit freed, or its resident size creeps up visit after visit
// (the soak measured +226 MiB over 36 minutes with keep_freed_memory's settings, the heap in use
// flat). Blocks of 1 MiB and more (camera frames, maps, accumulation buffers) are mapped and
// unmapped; the heap is trimmed when 8 MiB are free at its top; at most two malloc arenas, so
// that memory a worker thread freed is reused by the next worker instead of sitting in an arena
// of its own. The visit's page faults cost little next to its seconds of work. Call once at
// start, before any thread is created.
void bound_freed_memory();

// The kiosk's allocator (`glint run`, `glint replay`): jemalloc, Debian's libjemalloc2, preloaded
// by re-executing this program with LD_PRELOAD (a few ms, same PID, so systemd's notify and
// watchdog are unaffected). glibc's malloc fragments over the kiosk's visits even with
// bound_freed_memory: the soak measured +43 MiB resident from pass 1 to pass 2 with the heap in
// use flat, and under jemalloc +5 MiB (tests/bench/results/soak.md). Returns (and the program
// runs on glibc with bound_freed_memory) when jemalloc is preloaded already, when the library is
// not installed, in a sanitizer build (ASan must own malloc), or when GLINT_KIOSK_ALLOCATOR=glibc
// (valgrind, heap profilers). Call first thing in main, before any thread exists.
void reexec_with_kiosk_allocator(char** argv);

// The same choice for a program about to exec the kiosk: sets LD_PRELOAD (and marks the attempt)
// in this process's environment, so that the exec'd program starts on jemalloc and need not
// re-execute itself. `glint run` and `glint replay` exec glint-vision: each start of glint-vision
// costs 0.2-0.35 s (173 shared libraries to load and initialise), which the kiosk's start-up
// (target 1.5 s to the first frame) paid twice. Returns whether it set the preload.
bool preload_kiosk_allocator_for_exec();

// The allocator serving malloc in this process: "jemalloc", "glibc", or "asan" in an
// AddressSanitizer build.
const char* allocator_name();

// What the allocator reports: bytes the program has allocated and not freed, and bytes the
// allocator holds from the system for them (in use or kept free). glibc: mallinfo2 over every
// arena plus the mapped blocks; jemalloc: stats.allocated and stats.resident; AddressSanitizer:
// its allocator's counters. -1 when unknown.
struct HeapUsage {
    long long in_use_bytes = -1;
    long long held_bytes = -1;
};
HeapUsage heap_usage();

// Gives free memory inside malloc's heaps back to the kernel (glibc: malloc_trim, every arena,
// also pages in the middle of a heap; jemalloc: every arena's dirty pages purged). Returns true
// when some was returned (jemalloc: when the purge ran). Takes a few ms; the kiosk
// calls it once a visit, when the scene's work is done, and the soak after each pass.
bool return_freed_memory();

// Transparent huge pages for malloc's memory, which glibc (2.35+) takes only from its start-up
// tunables: if GLIBC_TUNABLES does not set glibc.malloc.hugetlb, sets it and re-executes this
// program with the same arguments (a few ms); returns if it is set already, or if the re-exec
// fails (the program then runs with 4 KiB pages, only slower). Fresh buffers of a convolution
// then fault in 2 MiB at a time instead of 4 KiB: on this VM the page faults were 13-29 % of
// `glint convolve`'s time, and the whole set from 1024x512 took half the time (measured
// 2026-12-02, docs/convolution.md). Call first thing in main, before any thread exists.
void reexec_with_huge_pages(char** argv);

}  // namespace glint
