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
/// Throws Error(Input) for an unreadable file, no solid, several solids without
/// `solid` (the message gives the count and says to pass --solid N), or a
/// tessellation that is not watertight.
SurfaceMesh readCadSurface(const std::string& path, const CadReadOptions& options = {});

}  // namespace tet2spline
