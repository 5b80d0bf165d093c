// Process-wide allocator settings for the programs (not the library: they
// are the process's choice).
//
// keepFreedMemory: keeps freed heap memory in the process instead of handing
// it back to the kernel. Every Newton iteration of the transport builds and
// frees a regular triangulation of ~100 MB (181k sites). With glibc's
// defaults the freed top of the heap is trimmed, so the next triangulation
// page-faults it back in: 477k page faults in the 181k-point benchmark, and
// page faults are dear on this virtual machine (perf: 6.5% of all cycles in
// the kernel's fault path). Keeping up to 1 GiB of free heap and serving
// blocks up to 32 MiB (glibc's maximum for this setting) from the heap cut
// the faults to 75k and the benchmark from 25.6 s to 21.4 s. Peak memory is
// unchanged: the memory kept is memory the process already had at its peak.
//
// useHugePages: every stage walks meshes of hundreds of MB in an order the
// caches do not predict (TetGen's cavities, the power diagrams, the
// untangler's tets), so on a virtual machine much of the time is address
// translation. glibc (2.35 and later) backs its heap with transparent huge
// pages when the tunable glibc.malloc.hugetlb=1 is set, and tunables are
// read only when a program starts: so the program runs itself once more with
// the tunable added, unless it is there already, the kernel's transparent
// huge pages are off ("never"), or TET2SPLINE_HUGEPAGES=0. A failed exec
// changes nothing. Measured on bunny00 (2026-12-07, AMD EPYC host, 380 of
// 412 MB resident in huge pages): `tet2spline param` 52.8, 52.8, 53.1 s ->
// 48.2, 49.7, 52.3 s, TetGen's refinement 6.4-6.7 -> 5.1-6.4 s, the same
// param.vtu (md5 f3f6cf41…).
#pragma once

#if defined(__GLIBC__)
#include <malloc.h>
#endif
#if defined(__linux__)
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#endif

namespace tet2spline::apps {

inline void keepFreedMemory() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024);
#endif
}

// Returns only if the program is not re-run (see above); call it first in main.
inline void useHugePages(char** argv) {
#if defined(__GLIBC__) && defined(__linux__)
  if (const char* choice = std::getenv("TET2SPLINE_HUGEPAGES"); choice && std::strcmp(choice, "0") == 0) return;
  const char* set = std::getenv("GLIBC_TUNABLES");
  if (set && std::strstr(set, "glibc.malloc.hugetlb")) return;  // set already, or the re-run
  const bool had = set != nullptr;
  const std::string before = had ? set : "";  // (a copy: setenv may replace the string)
  std::ifstream mode("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  if (!std::getline(mode, line) || line.find("[never]") != std::string::npos) return;
  const std::string value = (before.empty() ? std::string() : before + ":") + "glibc.malloc.hugetlb=1";
  if (::setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  ::execv("/proc/self/exe", argv);
  // Not re-run: go on as we are, without leaving the tunable to child processes.
  if (had) ::setenv("GLIBC_TUNABLES", before.c_str(), 1);
  else ::unsetenv("GLIBC_TUNABLES");
#else
  (void)argv;
#endif
}

}  // namespace tet2spline::apps
