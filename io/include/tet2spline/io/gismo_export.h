#pragma once
/// G+Smo XML export of a trivariate B-spline volume (design.md, "Export").
///
/// The file follows G+Smo's own volume files (filedata/volumes/*.xml, read by
/// gsFileData / gsXml<gsTensorBSpline<3>>):
///
///   <xml>
///    <Geometry type="TensorBSpline3" id="0">
///     <Basis type="TensorBSplineBasis3">
///      <Basis type="BSplineBasis" index="0"><KnotVector degree="p">U...</KnotVector></Basis>
///      ... index 1 (v), index 2 (w)
///     </Basis>
///     <coefs geoDim="3"> x y z per line, u fastest, then v, then w </coefs>
///    </Geometry>
///    <Matrix rows="#elements" cols="1" id="1" label="element_region"> ... </Matrix>
///   </xml>
///
/// G+Smo's tensor-product index is u fastest, as ours, so the coefficients are
/// the control points in our order. Knots are the full (clamped) sequences.
/// G+Smo has no per-element attribute inside a geometry; when element regions
/// are given they go into a separate `<Matrix>` (a type G+Smo reads,
/// gsXml<gsMatrix>) with id 1 and the extra attribute label="element_region":
/// one row per Bézier element in BSplineVolume::elements() order (u fastest).
/// Numbers are written as the shortest decimals that read back bit for bit.

#include <string>
#include <vector>

#include "tet2spline/spline/bspline_volume.h"

namespace tet2spline {

/// Writes `volume` to `path` (write-then-rename). `elementRegion` is empty or
/// has one entry per Bézier element. Throws Error(Usage) for a region vector
/// of the wrong size (before creating any file) and Error(Input) naming the
/// path when it cannot be written.
void writeGismoXml(const spline::BSplineVolume& volume, const std::string& path,
                   const std::vector<int>& elementRegion = {});

}  // namespace tet2spline
