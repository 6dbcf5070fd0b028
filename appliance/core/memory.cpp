#include "appliance/core/memory.hpp"

#include <malloc.h>

namespace glint {

void keep_freed_memory() {
    // Blocks up to 32 MiB (glibc's largest allowed threshold on 64-bit) come
    // from the heap and are reused after free; the heap is trimmed only when
    // 1 GiB is free at its top.
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, 1 << 30);
}

}  // namespace glint
