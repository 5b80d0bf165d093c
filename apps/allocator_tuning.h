// Keeps freed heap memory in the process instead of handing it back to the
// kernel, for the programs (not the library: it is a process-wide choice).
//
// Every Newton iteration of the transport builds and frees a regular
// triangulation of ~100 MB (181k sites). With glibc's defaults the freed
// top of the heap is trimmed, so the next triangulation page-faults it back
// in: 477k page faults in the 181k-point benchmark, and page faults are
// dear on this virtual machine (perf: 6.5% of all cycles in the kernel's
// fault path). Keeping up to 1 GiB of free heap and serving blocks up to
// 32 MiB (glibc's maximum for this setting) from the heap cut the faults to
// 75k and the benchmark from 25.6 s to 21.4 s. Peak memory is unchanged:
// the memory kept is memory the process already had at its peak.
#pragma once

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace tet2spline::apps {

inline void keepFreedMemory() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024);
#endif
}

}  // namespace tet2spline::apps
