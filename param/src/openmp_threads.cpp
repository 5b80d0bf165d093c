// OpenMP regions on the calling thread (openmp_threads.h).
#include <tet2spline/param/openmp_threads.h>

#include <dlfcn.h>

namespace tet2spline {

bool runOpenMpRegionsOnCallingThread() {
  using SetMaxActiveLevels = void (*)(int);
  // (looked up once; RTLD_DEFAULT searches every object loaded so far, which
  // includes CHOLMOD's libgomp whenever CHOLMOD is linked)
  static const SetMaxActiveLevels set =
      reinterpret_cast<SetMaxActiveLevels>(dlsym(RTLD_DEFAULT, "omp_set_max_active_levels"));
  if (set == nullptr) return false;
  set(0);
  return true;
}

}  // namespace tet2spline
