#pragma once
/// Material regions of a B-spline volume's Bézier elements and the element
/// density per region (design.md, "Materials and knots").
///
/// The spline x(u) was fitted to a parameterized tet mesh: vertices V (#V × 3,
/// physical), their parameters U (#V × 3, in the cube), tets T (#T × 4) with a
/// region tag each. An element belongs to the region of the tet whose
/// parameter image (the tet with corners U) contains the element's centre u_c.
/// With measure control a region of density w gets w times the parametric
/// volume per unit physical volume, so with uniform knots it gets w times the
/// elements per unit physical volume; regionElementDensity() measures that.
///
/// The parameter images of the tets do not cover the cube exactly where a
/// boundary triangle's corners lie on two different faces of the cube (it cuts
/// the cube's edge); a centre outside every image takes the tet that contains
/// it "most nearly" (largest smallest barycentric coordinate) among the tets
/// near it. Tets with degenerate parameter images are skipped.

#include <Eigen/Core>
#include <vector>

#include <tet2spline/spline/bspline_volume.h>

namespace tet2spline::spline {

/// Point location in the parameter images of a tet mesh: a uniform grid of
/// buckets over the images' bounding box, each holding the tets whose image's
/// bounding box meets it. Build once, query from any number of threads.
class ParameterLocator {
 public:
  /// Throws Error(Usage) for an empty mesh, indices out of range or
  /// non-finite parameters.
  ParameterLocator(const Eigen::MatrixX3d& U, const Eigen::MatrixX4i& T);
  /// The tet whose image contains u (ties: the one with the largest smallest
  /// barycentric coordinate), or, when none does, the nearest one in that
  /// sense among the tets in the nearest non-empty ring of buckets. -1 only
  /// when every tet's image is degenerate.
  long locate(const Eigen::Vector3d& u) const;
  /// Barycentric coordinates of u in tet t's image (sum 1; all >= 0 inside).
  Eigen::Vector4d barycentric(long t, const Eigen::Vector3d& u) const;

 private:
  long bucketIndex(int i, int j, int k) const { return i + static_cast<long>(n_[0]) * (j + static_cast<long>(n_[1]) * k); }
  Eigen::MatrixX3d U_;  ///< copies: the locator outlives its arguments
  Eigen::MatrixX4i T_;
  std::vector<Eigen::Matrix3d> inverse_;  ///< per tet: inverse of [U_b−U_a, U_c−U_a, U_d−U_a]; zero if degenerate
  Eigen::Vector3d lo_, hi_;
  Eigen::Vector3i n_;
  std::vector<long> first_, items_;  ///< bucket b holds items_[first_[b] .. first_[b+1])
};

/// Region of every Bézier element of `volume`, in BSplineVolume::elements()
/// order (u fastest): the region of the tet whose parameter image contains
/// the element's centre (see above). region: #T. Throws Error(Usage) on
/// mismatched sizes.
std::vector<int> elementRegions(const BSplineVolume& volume, const Eigen::MatrixX3d& U, const Eigen::MatrixX4i& T,
                                const Eigen::VectorXi& region);

/// Per region (ascending id): elements by centre and volumes.
struct RegionElementDensity {
  int id = 0;
  long elements = 0;              ///< Bézier elements whose centre lies in the region
  double volume = 0;              ///< physical volume: Σ |det| / 6 of its tets at V
  double parametricVolume = 0;    ///< Σ |det| / 6 of its tets at U
  double elementsPerVolume = 0;   ///< elements / volume (0 for a region of zero volume)
};

/// One entry per region present in `region` (ascending), from the element
/// regions of elementRegions(). Throws Error(Usage) on mismatched sizes.
std::vector<RegionElementDensity> regionElementDensity(const std::vector<int>& elementRegion,
                                                       const Eigen::MatrixX3d& V, const Eigen::MatrixX3d& U,
                                                       const Eigen::MatrixX4i& T, const Eigen::VectorXi& region);

}  // namespace tet2spline::spline
