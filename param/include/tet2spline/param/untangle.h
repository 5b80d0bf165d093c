#pragma once
/// Untangling of a tetrahedral map with fixed vertices (design.md, "Untangling").
///
/// Follows Garanzha, Kaporin, Kudryavtseva, Protais, Ray, Sokolov,
/// "Foldover-free maps in 50 lines of code" (SIGGRAPH 2021). With J_t the
/// Jacobian of the affine map from the reference tet t (the input tet, scaled
/// by the local volume ratio of the map around its vertices, so that det J ≈ 1
/// even where the map shrinks a part a thousandfold) to its image, the
/// energy is
///     E_ε(U) = Σ_t w_t [ (1−θ) tr(JᵀJ) / χ(det J, ε)^(2/3) + θ (det²J + 1) / χ(det J, ε) ],
///     χ(D, ε) = (D + sqrt(ε² + D²)) / 2,
/// w_t the reference volume over the mean one. It is minimised with L-BFGS
/// over the free vertices for a decreasing sequence of ε, set as in the
/// authors' reference code (invertible-maps, eq. (7)): ε = e₀ when every
/// det J > 0, else ε = sqrt(e₀² + 0.04 detmin²), with e₀ = 10⁻³ halved every
/// ten updates, and never increased (without that, sliding boundary vertices
/// oscillate between inverting and repairing; the slower schedule from the paper's theorem,
/// σ = max(1 − E/E_prev, 1/10), needed ten times more updates here), until no
/// tet is inverted, checked exactly. Because the
/// reference shapes are the input tets, the result also keeps their quality.
///
/// Only vertices within `rings` vertex rings of an inverted tet move (a few
/// dozen inverted tets in a 10⁶-tet map are repaired locally); the region is
/// doubled while inversions remain, up to every free vertex. Inversions are
/// counted exactly (orient3d, topology.h) before and after.
/// Energy and gradient are evaluated in parallel (TBB), deterministically.

#include <vector>

#include "tet2spline/param/error.h"
#include "tet2spline/param/progress.h"
#include "tet2spline/param/tet_mesh.h"

namespace tet2spline {

struct UntangleOptions {
  double theta = 0.5;              ///< weight of the volume term against the shape term
  int maxOuterIterations = 200;    ///< ε updates per region
  int maxLbfgsIterations = 100;    ///< L-BFGS iterations per ε
  int lbfgsMemory = 10;
  int stallIterations = 15;        ///< give up a region when min det J has not grown for this many ε updates
  int rings = 3;                   ///< initial free region (vertex rings) around inverted tets, doubled while it fails; < 0: all free vertices
  /// Outward triangles (indexing U) of a boundary that lies on the unit
  /// sphere. Their vertices that are not fixed may slide on the sphere
  /// (position y/|y|), and the cones (0, a, b, c) join the energy as extra
  /// tets, so no triangle flips on the sphere (orient3d(0,a,b,c) > 0).
  /// Needed when a tet with four boundary vertices is inverted by the
  /// spherical map itself: no interior move can repair it.
  Eigen::MatrixX3i sphereFaces;
  /// Per tet (#T, or empty): the volume each tet should have in the map.
  /// When given, reference tet t is scaled to this volume instead of by the
  /// local volume ratio above, so that untangling after the measure-controlled
  /// composition keeps each region's parametric volume (measured: a density-4
  /// region with 20% of the volume fell to 11% when scaled by local ratios).
  Eigen::VectorXd targetVolumes;
  /// Minimise the energy over every free vertex even when nothing is
  /// inverted (one ε round of at most maxLbfgsIterations): moves the map
  /// towards the reference shapes and targetVolumes without ever inverting
  /// a tet (the barrier keeps det J > 0).
  bool relax = false;
  ProgressCallback progress = {};  ///< called once per ε update; false stops
};

struct UntangleResult {
  Eigen::MatrixX3d U;              ///< #V × 3; fixed vertices unchanged (bitwise)
  int invertedBefore = 0;          ///< exact count of tets with orient3d <= 0, before
  int invertedAfter = 0;           ///< and after
  int outerIterations = 0;         ///< ε updates, summed over regions
  int lbfgsIterations = 0;
  int freeVertices = 0;            ///< vertices that moved in the last region
  int flippedSphereTriangles = 0;  ///< exact, of options.sphereFaces, at the end
  double minDet = 0;               ///< smallest det J at the end (floating point)
  Status status;                   ///< failure when inversions remain or progress stopped it
};

/// Untangles U (#V × 3), the image of the reference mesh (reference #V × 3,
/// T #T × 4, positively oriented), keeping the vertices with fixed[i] == true.
/// Throws Error(Input) for mismatched shapes or a reference tet of
/// non-positive volume.
UntangleResult untangle(const Eigen::MatrixX3d& reference, const Eigen::MatrixX4i& T, const Eigen::MatrixX3d& U,
                        const std::vector<bool>& fixed, const UntangleOptions& options = {});

}  // namespace tet2spline
