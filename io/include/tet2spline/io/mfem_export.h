#pragma once
/// MFEM NURBS mesh v1.0 export of a trivariate B-spline volume, "patches"
/// form (design.md, "Export"), as in MFEM's own data/ball-nurbs-single-patch.mesh
/// and read by mfem::NURBSExtension(std::istream&):
///
///   MFEM NURBS mesh v1.0
///   dimension 3
///   elements 1:   "attr 5 0 1 2 3 4 5 6 7" — the patch as one hexahedron
///                 (geometry 5 = CUBE) with MFEM's vertex order, counter-
///                 clockwise on the bottom then the top: parameter corners
///                 0 (0,0,0) 1 (1,0,0) 2 (1,1,0) 3 (0,1,0), 4..7 the same at w = 1.
///   boundary 6:   "attr 3 a b c d" (3 = SQUARE), outward, in MFEM's hex face
///                 order (Geometry::Constants<CUBE>::FaceVert): w = 0, v = 0,
///                 u = 1, v = 1, u = 0, w = 1. Attribute = our VolumeFace + 1
///                 (UMin 1, UMax 2, VMin 3, VMax 4, WMin 5, WMax 6).
///   edges 12:     "knotvector v0 v1": the patch's direction (0 u, 1 v, 2 w),
///                 listed from the low-parameter end to the high one (MFEM
///                 flips the knot vector of an edge whose v0 > v1).
///   vertices 8    (no coordinates: the geometry is in the patch)
///   patches, then for the patch:
///     knotvectors 3, one line per direction "order ncp knots..." with MFEM's
///     order = the degree, ncp = number of control points, the full knots;
///     dimension 3; controlpoints_cartesian: "x y z w" per line (w = 1, our
///     splines are polynomial), u fastest, then v, then w.
///
/// MFEM reads KnotVector(0) of the patch for edge 0 (0→1), KnotVector(1) for
/// edge 3 (0→3) and KnotVector(2) for edge 8 (0→4), which is our u, v, w.
///
/// Materials: MFEM's NURBS patch topology has one element attribute per
/// patch (the refined NURBS elements inherit it), so the patch gets
/// `elementAttribute` (default 1). Per-element regions are not representable
/// in this single-patch form; writeMfemElementRegions writes them as an MFEM
/// GridFunction file beside the mesh (and they are in the VTU and G+Smo exports).

#include <string>
#include <vector>

#include "tet2spline/spline/bspline_volume.h"

namespace tet2spline {

struct MfemExportOptions {
  int elementAttribute = 1;  ///< attribute of the patch (MFEM attributes are >= 1)
};

/// Writes `volume` as an MFEM NURBS mesh (write-then-rename). Throws
/// Error(Usage) for an attribute < 1 and Error(Input) naming the path when it
/// cannot be written.
void writeMfemNurbsMesh(const spline::BSplineVolume& volume, const std::string& path,
                        const MfemExportOptions& options = {});

/// The region of each Bézier element as an MFEM GridFunction (the format of
/// mfem::GridFunction::Save, read by GridFunction(Mesh*, std::istream&)) on
/// the mesh written by writeMfemNurbsMesh: a piecewise-constant L2 space,
///
///   FiniteElementSpace
///   FiniteElementCollection: L2_3D_P0
///   VDim: 1
///   Ordering: 0
///   <blank line>
///   one value per element
///
/// MFEM numbers the elements of a NURBS patch with u fastest, then v, then w
/// (NURBSExtension::Get3DElementTopo, non-empty spans only), which is the
/// order of BSplineVolume::elements() and of `elementRegion`. Throws
/// Error(Usage) when the size is not the number of elements (before creating
/// any file) and Error(Input) naming the path when it cannot be written.
void writeMfemElementRegions(const spline::BSplineVolume& volume, const std::vector<int>& elementRegion,
                             const std::string& path);

}  // namespace tet2spline
