#pragma once
/// STEP and IGES input through OpenCASCADE.

#include <string>

#include "tet2spline/param/tet_mesh.h"

namespace tet2spline {

struct CadReadOptions {
  double relativeDeflection = 1e-3;  ///< linear deflection as a fraction of the bounding-box diagonal
  double angularDeflection = 0.35;   ///< radians
  int solid = 0;                     ///< 1-based solid to take when the file has several; 0 = expect exactly one
};

/// Reads a STEP (.step/.stp) or IGES (.iges/.igs) file, takes its one solid (or
/// `options.solid`), and tessellates it into a closed, consistently oriented
/// triangle surface whose shells are the solid's shells (outer and voids).
///
/// Files without solids (IGES written as trimmed faces) are sewn; each closed
/// shell becomes a solid, and a shell nested inside another one is a void of
/// it. An invalid solid (BRepCheck) is repaired with ShapeFix when that keeps
/// all its shells, and refused otherwise.
///
/// Output: faces share the nodes of their common edges, so the surface is
/// watertight (every directed edge once, its reverse once). Orientation
/// convention (what the mesher expects): normals point out of the material on
/// every shell, i.e. the outer shell encloses a positive signed volume and
/// each void shell a negative one. Shells are the connected components.
///
/// Throws Error(Input) with one line "file: cause" for an unreadable, empty,
/// truncated or malformed file (entities that fail to load, reals beyond 1e15,
/// translator failures), no solid, several solids without `solid` (the message
/// gives the count and says to pass --solid N (1..count)), a solid that cannot
/// be repaired, or a tessellation that is not watertight. Throws Error(Usage)
/// for `solid` out of range or non-positive deflections. OpenCASCADE exceptions
/// become Error(Input); while the file is read, OCCT's signal handlers turn
/// access violations inside OCCT into exceptions (handlers the application set
/// itself are kept, and all are restored afterwards), so this function is not
/// meant to run concurrently with other OCCT work. Some malformed IGES files
/// can still make OCCT loop for a long time.
SurfaceMesh readCadSurface(const std::string& path, const CadReadOptions& options = {});

}  // namespace tet2spline
