#pragma once
/// OpenMP parallel regions started by the calling thread run on that thread
/// alone.
///
/// Why: Debian's CHOLMOD (SuiteSparse 5) runs the assembly loops of its
/// supernodal factorisation in OpenMP teams of a compiled-in four threads
/// (CHOLMOD_OMP_NUM_THREADS; OMP_NUM_THREADS cannot lower a num_threads
/// clause). On a two-core machine those teams mostly wait on one another:
/// measured on bunny00's spherical map (14–17 factorisations of 113k rows,
/// `param` on its TetGen mesh), a fifth of the stage's samples were futex
/// waits and wake-ups under GOMP_parallel, and the stage took 8.1–9.9 s
/// against 5.7–6.1 s with the teams at one thread (OMP_THREAD_LIMIT=1); the
/// whole `convert` 87.1 and 89.7 s against 78.4 and 84.1 s. The loops write
/// disjoint entries, so the factor is the same bits either way.
///
/// How: OpenMP's max-active-levels of the calling thread is set to 0, so
/// every region it starts is inactive (a team of one). The setting is per
/// thread (libgomp keeps it in the thread's data environment): the library
/// calls this before each CHOLMOD factorisation, in the thread that runs it.
/// The OpenMP runtime is looked up at run time, so nothing links against it;
/// without one loaded (a CHOLMOD built without OpenMP) this does nothing.
///
/// Returns whether an OpenMP runtime was found (and the setting made).

namespace tet2spline {

bool runOpenMpRegionsOnCallingThread();

}  // namespace tet2spline
