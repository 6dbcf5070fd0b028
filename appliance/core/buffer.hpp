// Large numeric scratch buffers that are not zeroed on allocation.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <utility>
#include <vector>

namespace glint {

// Asks the kernel to back a large buffer that is about to be written with transparent huge
// pages (2 MiB, madvise mode: Debian's default). A 100 MB map is then 50 page faults instead of
// 25,000; on a virtual machine each fault is a trip through the hypervisor, and the first pass
// over a fresh 4096x2048 output cost more in faults than in arithmetic (docs/convolution.md,
// "Fresh memory"). Buffers under 4 MiB are left alone. Advice only: a kernel without THP, or
// with it set to `never`, ignores it. Not under jemalloc (memory.cpp says why).
void advise_huge_pages(void* p, std::size_t bytes) noexcept;
// The whole 2 MiB pages inside [p, p + bytes) that advise_huge_pages advises: [begin, end),
// empty (begin == end) for a block under 4 MiB or one holding no whole huge page.
struct HugePageSpan {
    std::uintptr_t begin = 0, end = 0;
};
HugePageSpan huge_page_span(const void* p, std::size_t bytes) noexcept;

// An allocator whose value-less construct() default-initialises: for double
// and float, no write at all. resize(n) of a 3 MB buffer then costs nothing,
// where std::vector<double>(n) zeroes it on one thread before the parallel
// loop that writes every element anyway (measured: ~5 % of the auto whole set).
template <typename T>
struct DefaultInitAllocator : std::allocator<T> {
    template <typename U>
    struct rebind {
        using other = DefaultInitAllocator<U>;
    };
    using std::allocator<T>::allocator;
    T* allocate(std::size_t n) {
        T* p = std::allocator<T>::allocate(n);
        advise_huge_pages(p, n * sizeof(T));
        return p;
    }
    template <typename U>
    void construct(U* p) noexcept {
        ::new (static_cast<void*>(p)) U;
    }
    template <typename U, typename... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};

// A vector whose resize() leaves new elements uninitialised: every element
// must be written before it is read.
template <typename T>
using UninitVector = std::vector<T, DefaultInitAllocator<T>>;

}  // namespace glint
