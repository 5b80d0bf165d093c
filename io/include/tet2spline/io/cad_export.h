#pragma once
/// STEP and IGES export of a trivariate B-spline volume's boundary as a B-rep
/// solid (design.md, "Export"). Neither OpenCASCADE nor IGES has trivariate
/// geometry, so the solid is bounded by the six boundary faces of the volume,
/// each an exact B-spline surface: same degrees and knots as the volume in its
/// two directions, control points = the outer layer of the control grid
/// (BSplineVolume::face, oriented outward). The faces are sewn (tolerance
/// relative to the bounding-box diagonal of the control points; adjacent faces
/// share their boundary curves exactly, since they share control points), made
/// into a shell and a solid, oriented with ShapeFix_Solid and checked with
/// BRepCheck_Analyzer.
///
/// STEP: AP214 (schema AP214IS), written by STEPControl_Writer as a manifold
/// solid B-rep. IGES: 5.3 in BRep mode (write.iges.brep.mode = 1: MSBO solid
/// with B-spline surface entities, type 128), IGESControl_Writer. Lengths are
/// written with the writers' default unit (millimetre) and the coordinates as
/// they are: 1 model unit = 1 mm. Header fields that would hold the time or
/// the user (STEP FILE_NAME time stamp and author, IGES dates and author) are
/// fixed ("tet2spline", 1970-01-01) and the STEP product is named after the
/// file's stem, so the same volume and file name give the same bytes.
///
/// Preconditions: det J > 0 inside the volume, so that the boundary is a
/// closed surface; det J may vanish along the 12 edges of the parameter cube
/// (two faces meeting tangentially), which sewing handles.

#include <string>

#include "tet2spline/spline/bspline_volume.h"

namespace tet2spline {

struct CadExportOptions {
  /// Sewing tolerance as a fraction of the bounding-box diagonal of the
  /// control points (the faces share edges exactly; this only absorbs rounding).
  double relativeSewingTolerance = 1e-7;
};

/// Writes the boundary of `volume` as a STEP AP214 solid (write-then-rename).
/// Throws Error(Numerical) naming the path when sewing does not give one
/// valid closed solid (nothing is written then) and Error(Input) naming the
/// path when the file cannot be written.
void writeStep(const spline::BSplineVolume& volume, const std::string& path, const CadExportOptions& options = {});

/// Writes the boundary of `volume` as an IGES 5.3 BRep solid; errors as writeStep.
void writeIges(const spline::BSplineVolume& volume, const std::string& path, const CadExportOptions& options = {});

}  // namespace tet2spline
