// Process-wide memory settings of the appliance's long-running programs.
#pragma once

namespace glint {

// Keeps large freed blocks in the process instead of returning them to the
// kernel. The convolution engine allocates and frees buffers of 1-20 MiB for
// every map (sums, levels, SH tables); with glibc's defaults each comes from a
// fresh mmap and its first touch costs a page fault per 4 KiB (measured: 14 %
// of the auto whole set's wall time). The appliance's working set is bounded
// (peak under 100 MiB for the whole set, docs/convolution.md), so holding on
// to it is cheap. Call once at start, before any thread is created.
void keep_freed_memory();

}  // namespace glint
