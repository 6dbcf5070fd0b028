// A fork-join loop for the numeric engines. The thread count is passed in by
// the caller, as filament's IBL library does; the threads themselves are kept
// in one process-wide pool, since the convolution of a whole set makes ~100
// short loops and starting threads for each cost ~5 % of its time.
#pragma once

#include <functional>

namespace glint {

// Number of hardware threads, at least 1.
int hardware_threads();

// Runs body(i) for i in [0, count) on `threads` threads (the caller's and
// threads - 1 pool workers), handing out indices dynamically (rows near the
// poles cost less than rows at the equator). Exceptions thrown by body are
// rethrown on the caller's thread. A parallel_for inside a body runs serially
// on that body's thread; loops from different caller threads take turns.
void parallel_for(int count, int threads, const std::function<void(int)>& body);

}  // namespace glint

namespace glint {

// Lowers the calling thread's scheduling priority (nice 10): for background
// work like a convolution job, so the render thread and the GL driver's
// threads keep the cores first. Its parallel_for loops from then on run on a
// pool of their own whose workers are lowered too. Returns false if the
// system refused.
bool lower_this_thread_priority();

}  // namespace glint
