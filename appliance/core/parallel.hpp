// A minimal fork-join loop for the numeric engines. The thread count is passed
// in by the caller (no global pool), as filament's IBL library does.
#pragma once

#include <functional>

namespace glint {

// Number of hardware threads, at least 1.
int hardware_threads();

// Runs body(i) for i in [0, count) on `threads` threads, handing out indices
// dynamically (rows near the poles cost less than rows at the equator).
// Exceptions thrown by body are rethrown on the caller's thread.
void parallel_for(int count, int threads, const std::function<void(int)>& body);

}  // namespace glint
