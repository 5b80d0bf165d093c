#pragma once
/// VTK (.vtu) views of a trivariate B-spline volume for ParaView
/// (design.md, "Export").
///
/// writeSplineVtu samples the spline on a hexahedral grid: every knot span of
/// every direction is split into `samplesPerSpan` equal parameter steps, so
/// the grid has (s·N_d + 1) points and s·N_d cells per direction (N_d knot
/// spans), points u fastest, then v, then w. Cells are VTK_HEXAHEDRON (12)
/// with VTK's corner order (0,0,0) (1,0,0) (1,1,0) (0,1,0) then the same at
/// the upper w, so a cell has positive volume where det J > 0. Point data:
/// "detJ" (det of the Jacobian, Float64) and "scaledJacobian" (det J divided
/// by the product of the column norms, in [−1, 1]); point "parameter" (u,v,w).
/// Cell data: "region" (Int32) of the Bézier element holding the cell, from
/// `elementRegion` (one entry per element, BSplineVolume::elements() order),
/// −1 when no regions are given; "element" (Int32) the element index.
///
/// writeControlNetVtu writes the control grid: points = control points (u
/// fastest), VTK_LINE (3) cells between neighbours along u, then v, then w;
/// point data "index" (i, j, k) as Int32 × 3.
///
/// Files are VTK XML UnstructuredGrid 1.0 with header_type UInt64, either
/// appended raw binary (little or big endian as the host, declared in
/// byte_order) or ASCII, written to a temporary name and renamed.

#include <string>
#include <vector>

#include "tet2spline/spline/bspline_volume.h"

namespace tet2spline {

struct SplineVtuOptions {
  int samplesPerSpan = 4;  ///< parameter steps per knot span per direction (>= 1)
  bool binary = true;      ///< appended raw binary; false = ASCII
};

/// Throws Error(Usage) for samplesPerSpan < 1 or a region vector whose size is
/// not the number of elements (before creating any file); Error(Input) naming
/// the path when it cannot be written.
void writeSplineVtu(const spline::BSplineVolume& volume, const std::string& path,
                    const std::vector<int>& elementRegion = {}, const SplineVtuOptions& options = {});

/// Throws Error(Input) naming the path when it cannot be written.
void writeControlNetVtu(const spline::BSplineVolume& volume, const std::string& path, bool binary = true);

}  // namespace tet2spline
