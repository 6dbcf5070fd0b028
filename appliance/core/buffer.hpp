// Large numeric scratch buffers that are not zeroed on allocation.
#pragma once

#include <memory>
#include <new>
#include <utility>
#include <vector>

namespace glint {

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
