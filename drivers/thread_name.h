// Names for the daemon's threads, so that `top -H`, perf and tests/bench tell the cameras, the
// pipeline's stages and the web view apart.
#pragma once

#include <pthread.h>

namespace mocap {

// Names the calling thread: at most 15 characters (Linux drops longer names).
inline void nameThisThread(const char* name) { pthread_setname_np(pthread_self(), name); }

}  // namespace mocap
