#pragma once
/// Power (Laguerre) diagrams clipped to the OT target domain Ω (design.md,
/// "Semi-discrete optimal transport").
///
/// For sites y_i (#N × 3) and weights ψ_i (#N), the Laguerre cell is
///   Lag_i = { x ∈ Ω : |x − y_i|² − ψ_i ≤ |x − y_j|² − ψ_j for all j }.
/// `computePowerDiagram` returns, for every cell, its volume, its centroid and
/// the area of the facet it shares with each neighbour inside Ω (what the
/// Hessian of the Kantorovich dual needs). The neighbours come from a CGAL
/// regular triangulation (built sequentially after a spatial sort: CGAL 5.5's
/// parallel insertion has a race), or from a previous diagram's
/// triangulation repaired by flips (`seed`). Cells inside Ω are then measured from the
/// triangulation's dual (power centres), the others clipped independently by a
/// small convex-polytope clipper (both in parallel, TBB; see CellMeasure), so
/// volumes, centroids and areas are exact for the polytope up to rounding.
/// CGAL stays inside the .cpp.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <vector>

namespace tet2spline {

/// The OT target domain Ω: the unit cube [0,1]^3, or the unit ball centred at
/// the origin represented by a convex polytope.
///
/// Ball representation: the polytope circumscribed about the unit sphere whose
/// facets are the tangent planes n_k · x ≤ 1 at the vertices n_k of a geodesic
/// sphere (icosahedron split `subdivisions` times; level s has 10·4^s + 2
/// planes). It contains the closed unit ball, so points ON the unit sphere are
/// inside Ω. Its volume exceeds 4π/3 by a relative 3.0e-4 at level 5
/// (10242 planes), 7.5e-5 at the default level 6 (40962 planes, built in
/// 0.06 s), 1.9e-5 at level 7 (0.35 s); its vertices lie within 7e-5 of the
/// sphere at level 6. `volume()` is the polytope's own volume, which the OT
/// uses, so masses balance exactly. Each Laguerre cell is
/// clipped only by the tangent planes that actually cut it, found by a
/// hill-climb over the geodesic sphere, so the cost grows with the cells on
/// the boundary, not with the number of planes — as long as boundary cells
/// are not much larger than the plane spacing (0.018 at level 6, i.e. from
/// about 50k points on). With few points, pick a coarser level.
class Domain {
 public:
  enum class Kind { Cube, Ball };

  /// [0,1]^3.
  static Domain unitCube();
  /// The polytope described above; `subdivisions` in [0, 8].
  static Domain unitBall(int subdivisions = 6);

  Kind kind() const { return kind_; }
  /// |Ω| of the represented domain: 1 for the cube, the polytope's volume for
  /// the ball (4π/3 · (1 + relative error)).
  double volume() const { return volume_; }
  /// Ω ⊂ box (for the ball: the polytope's bounding box).
  const Eigen::AlignedBox3d& boundingBox() const { return box_; }
  /// A point inside Ω used as the centre of scalings (cube centre, origin).
  Eigen::Vector3d center() const;
  /// Whether x ∈ Ω, allowing `tolerance` outside the bounding planes.
  bool contains(const Eigen::Vector3d& x, double tolerance = 0) const;

  /// Ball only: unit outward normals of the tangent planes (#planes × 3) and,
  /// for each plane, the planes adjacent to it on the geodesic sphere.
  const Eigen::MatrixX3d& planeNormals() const { return normals_; }
  const std::vector<std::vector<int>>& planeNeighbours() const { return adjacency_; }
  /// Ball only: index of the plane maximising n_k · x (hill-climb from
  /// `start`, exact because the geodesic sphere is the normals' convex hull).
  int mostExposedPlane(const Eigen::Vector3d& x, int start = -1) const;

 private:
  Kind kind_ = Kind::Cube;
  double volume_ = 1;
  Eigen::AlignedBox3d box_;
  Eigen::MatrixX3d normals_;
  std::vector<std::vector<int>> adjacency_;
};

/// Laguerre cells of N sites clipped to Ω. Neighbours are listed per cell in
/// compressed rows: the neighbours of i are neighbour[k] for k in
/// [neighbourStart[i], neighbourStart[i+1]), increasing, with the area of the
/// shared facet in facetArea[k]. The list holds every neighbour of the regular
/// triangulation, so some areas are 0 (the facet lies outside Ω).
struct PowerDiagram {
  Eigen::VectorXd volumes;           ///< |Lag_i|, #N; 0 for an empty cell
  Eigen::MatrixX3d centroids;        ///< #N × 3; the site itself for an empty cell
  std::vector<int> neighbourStart;   ///< #N + 1
  std::vector<int> neighbour;        ///< site indices, #neighbourStart[N]
  std::vector<double> facetArea;     ///< |Lag_i ∩ Lag_j|, aligned with `neighbour`
  int hiddenSites = 0;               ///< sites that are no vertex of the regular triangulation (empty cells)
  double triangulationSeconds = 0;   ///< regular triangulation + neighbour lists
  double clippingSeconds = 0;        ///< measuring the cells: dual polygons and clipping (parallel)
  int clippedCells = 0;              ///< cells measured by the clipper (the rest from the dual, see below)
  /// The regular triangulation behind the diagram (empty when the sites
  /// span less than 3 dimensions): its finite tets as site indices,
  /// positively oriented, and per tet the tet across the face opposite each
  /// slot (−1 on the sites' convex hull). Another diagram of the same sites
  /// can start from it (computePowerDiagram's `seed`).
  std::vector<std::array<int, 4>> tetVertex, tetNeighbour;
  Eigen::VectorXd triangulationWeights;  ///< the weights (without tails) it is regular for; empty with no tets
  bool repaired = false;             ///< the triangulation came from a seed by flips, not from CGAL's insertion
  /// Repaired: 1 when the flips went straight to the new weights; 2 or 4
  /// when they went there in that many equal parts after stalling (see
  /// computePowerDiagram). 0 when not repaired.
  int repairParts = 0;
  long flips = 0;                    ///< flips tried on the seed's triangulation (also when the repair gave up)
  /// The diagram was not built: `rejectBelow` (computePowerDiagram) proved
  /// a cell smaller than asked. Only `flips`, `repaired` (false) and
  /// `triangulationSeconds` are then set; the volumes are 0.
  bool rejected = false;
};

/// How `computePowerDiagram` measures the cells.
enum class CellMeasure {
  /// A cell whose power vertices (the power centres of its tets in the
  /// regular triangulation) all lie in Ω, with no tet flatter than a
  /// conditioning bound, is the convex hull of those vertices: its facets are
  /// the polygons of power centres around its triangulation edges, so volume,
  /// centroid and facet areas come from the dual directly. The other cells
  /// (on ∂Ω, on the sites' convex hull, next to a flat tet) are clipped.
  /// Default.
  DualWhereInside,
  /// Every cell clipped from Ω by its neighbours' planes (the reference the
  /// tests compare with).
  ClipAll,
};

/// The power diagram of sites `points` (#N × 3) with weights `weights` (#N),
/// power distance |x − y_i|² − ψ_i, clipped to `domain`.
/// Sites may lie outside Ω (their cells may then be empty). Coincident sites:
/// the one with the larger weight (on a tie, one of them) owns the cell, the
/// others are hidden and get empty cells; never a crash.
/// Throws Error(Usage) if the sizes disagree and Error(Input) for non-finite
/// coordinates or weights.
/// `presorted`: skip the diagram's own spatial sort and the copy back to the
/// input order (about 0.1 s of a 0.9 s diagram at 181k sites). The result is
/// right for sites in any order, and fast when they are in spatialOrder
/// (below), which a caller that builds many diagrams of the same sites can
/// arrange once.
/// `weightTails` (#N, or null): low-order parts of the weights, ψ_i =
/// weights[i] + weightTails[i] to about twice double precision. The cells
/// depend on differences ψ_i − ψ_j of neighbours, which a double ψ of
/// order 0.1 holds only to about 10⁻¹⁷. Measured on hand.off's cube
/// transport: changing every ψ by a random 5·10⁻¹⁸ changed its smallest
/// cells (10⁻¹³ of Ω) by 10⁻⁶ of their volume (optimal_transport.h).
/// The regular triangulation's combinatorics use the weights alone.
/// `seed` (or null): a diagram of the same sites (same order) under other
/// weights. Its triangulation is repaired by 2-3 and 3-2 flips (Lawson's
/// algorithm, exact predicates) instead of inserting every site again: when
/// the weights moved little, as between Newton steps of the transport, that
/// is a fraction of the insertion's time. When flips cannot do it (the seed
/// hides sites, a site would become hidden, the flips stall, sites lie on
/// the convex hull without being its corners) the triangulation is built
/// from scratch. Both ways give the same tets in the same canonical order,
/// so the result does not depend on the seed (up to ties of the power test:
/// then either regular triangulation may come out, measuring the same cells
/// up to rounding). Lawson's flips can stall in 3D on facets that no 2-3 or
/// 3-2 flip removes, where a continuous change of the weights would have
/// passed through other flips first: after a stall (or more flips than a
/// quarter of the tets) that proves no cell below `rejectBelow`, the repair
/// goes from the seed's weights to the new ones in 2, then 4 equal parts,
/// each part repaired from the regular triangulation of the last.
/// `rejectBelow` (with a seed; 0: never): a caller that will discard a
/// diagram with a cell below this volume (the transport's line search) lets
/// a repair that fails end there when it can prove such a cell: the sites
/// of the facets the flips left non-regular are clipped by their neighbours
/// in the flipped triangulation, a superset of their Laguerre cells, and if
/// one of those is below `rejectBelow` the result is `rejected` instead of
/// a triangulation built from scratch (0.9 s at 181k sites). When a weight
/// change hides a site, the flips stall around it, and this is what proves
/// its cell empty.
PowerDiagram computePowerDiagram(const Eigen::MatrixX3d& points, const Eigen::VectorXd& weights,
                                 const Domain& domain, CellMeasure measure = CellMeasure::DualWhereInside,
                                 bool presorted = false, const Eigen::VectorXd* weightTails = nullptr,
                                 const PowerDiagram* seed = nullptr, double rejectBelow = 0);

/// The order (a permutation of 0..#N−1) in which computePowerDiagram works:
/// CGAL's Hilbert sort with the median policy. A caller that builds many
/// diagrams of the same sites can order them so once (see `presorted`).
std::vector<int> spatialOrder(const Eigen::MatrixX3d& points);

}  // namespace tet2spline
