#pragma once
/// Untangling of a tetrahedral map with fixed vertices (design.md, "Untangling").
///
/// Follows Garanzha, Kaporin, Kudryavtseva, Protais, Ray, Sokolov,
/// "Foldover-free maps in 50 lines of code" (SIGGRAPH 2021). With J_t the
/// Jacobian of the affine map from the reference tet t (the input tet, scaled
/// to the map's size there; see "Scale" below) to its image, the
/// energy is
///     E_ε(U) = Σ_t w_t [ (1−θ) tr(JᵀJ) / χ(det J, ε)^(2/3) + θ (det²J + 1) / χ(det J, ε) ],
///     χ(D, ε) = (D + sqrt(ε² + D²)) / 2,
/// w_t = 1 (see below). It is minimised with L-BFGS
/// over the free vertices for a decreasing sequence of ε, set as in the
/// authors' reference code (invertible-maps, eq. (7)): ε = e₀ when every
/// det J > 0, else ε = sqrt(e₀² + 0.04 detmin²), with e₀ = 10⁻³ halved every
/// ten updates, and never increased (without that, sliding boundary vertices
/// oscillate between inverting and repairing; the slower schedule from the paper's theorem,
/// σ = max(1 − E/E_prev, 1/10), needed ten times more updates here), until no
/// tet is inverted, checked exactly. Because the reference shapes are the
/// input tets, the result also keeps their quality.
///
/// Scale. A conformal spherical map shrinks protrusions enormously: mapped
/// edges span 10⁻⁸ .. 10⁻¹ on triceratops and 10⁻⁵ .. 10⁻¹ on homer. So
///  - each reference tet is the input tet scaled by its own map scale
///    s_t = sqrt(Σ|Δu|²/Σ|Δx|²) over its six edges (det J ≈ 1 for a
///    well-shaped image at any scale; edge lengths, unlike volumes, stay
///    meaningful for inverted and flat tets);
///  - every tet has weight 1 (with reference-volume weights, tets in small
///    features weighed 10⁻⁶ of the mean and L-BFGS traded their inversion
///    for energy elsewhere);
///  - the unknowns are displacements in units of h_v / sqrt(#tets at v), h_v
///    the geometric mean of the mapped edges at v (a diagonal preconditioner:
///    the Hessian is O(1) at every vertex; without it homer's 8 inversions
///    took 74 s, with it about 1 s), and J is formed from edge vectors
///    (no cancellation where a tet is 10⁻⁸ wide at |u| = 1).
///
/// Only vertices within `rings` vertex rings of an inverted tet move (a few
/// dozen inverted tets in a 10⁶-tet map are repaired locally); the region is
/// doubled while inversions remain, up to every free vertex. Inversions are
/// counted exactly (orient3d, topology.h) before and after.
/// Energy and gradient are evaluated in parallel (TBB), deterministically.
///
/// Sliding boundaries. With `sphereFaces` (the ball) or `cubeFaces` (the
/// unit cube [0,1]³, for the composition with optimal transport) the
/// boundary vertices that are not fixed slide on that boundary, and the
/// cones (c, a, b, d) from the domain's centre c (origin, or (½,½,½)) over
/// the boundary triangles (a, b, d) join the energy as extra tets with the
/// same barrier, so no boundary triangle flips: orient3d(c, a, b, d) > 0,
/// counted exactly. Both domains are star-shaped from c, so positive cones
/// mean a bijective boundary. On the cube, a vertex's locked coordinates
/// (those on which it lies on a face; three for a corner) are never changed,
/// not even by rounding, and its free ones are clamped to [0, 1].

#include <cstdint>
#include <vector>

#include "tet2spline/param/error.h"
#include "tet2spline/param/progress.h"
#include "tet2spline/param/tet_mesh.h"

namespace tet2spline {

/// How each ε round is minimised.
///  - Lbfgs: L-BFGS with Armijo backtracking (cheap iterations).
///  - Newton: projected Newton. Each tet's Hessian in J is projected onto the
///    PSD cone through its analytic eigensystem (Smith et al. 2019), mapped
///    to the unknowns through the reference gradients, the preconditioner and
///    the sliding constraints (Gauss–Newton for y ↦ y/|y|; coordinates at a
///    bound of the cube held, as in L-BFGS-B), factorised with CHOLMOD (the
///    symbolic analysis once per region), and a backtracking line search.
///    At most maxNewtonIterations per ε; a round ends early once every det J
///    is positive.
/// Measured (2 cores; the ball map of the cube pipeline, whose boundary was
/// made nearly equiareal): spool 65 s and 1 tet left inverted with L-BFGS,
/// 13 s and none with Newton; hand 34 s with some left, against 153 s and
/// none; triceratops 17 s against 26 s, none left. On the composition's many
/// shallow inversions L-BFGS is far faster (final untangling of fandisk
/// 2.4 s against 60 s), and neither repairs the last inversions of spool's
/// or hand's final untangling: there tets in slabs about 10⁻² thick along
/// a cube face keep det J ≈ −ε/2 whatever the method, a conflict of the
/// configuration, not of the minimiser. Hence L-BFGS by default. (Those
/// ball maps now end bijective with L-BFGS too: the local max-min repair
/// after the energy, see localRepairSweeps, fixes what it leaves, 25 tets
/// on hand and 1 on spool; hand's map takes 18 s. Measured again on spool's
/// final untangling on the cube: the repair takes 75 inversions after the
/// first phase to 10, but 6 remain at the end, flat, each with three interior
/// vertices and one on a face: max-min moves of one vertex at a time,
/// widened to four rings, leave their least volume at 0.)
enum class UntangleMethod { Lbfgs, Newton };

struct UntangleOptions {
  UntangleMethod method = UntangleMethod::Lbfgs;
  double theta = 0.5;              ///< weight of the volume term against the shape term
  int maxOuterIterations = 200;    ///< ε updates per region
  int maxLbfgsIterations = 100;    ///< L-BFGS iterations per ε
  int lbfgsMemory = 10;
  int maxNewtonIterations = 20;    ///< Newton iterations per ε (method Newton)
  /// ε updates a region gets while inversions remain; then it grows (see
  /// `rings`). A fixed budget, not "until min det J stops growing": min det
  /// keeps creeping up by a few per cent a round, and waiting for it
  /// to stop took homer's final untangling from 91 s to 238 s (cube) and
  /// fandisk's from 16 s to 89 s (ball).
  int regionRounds = 16;
  int rings = 3;                   ///< initial free region (vertex rings) around inverted tets, doubled while it fails; < 0: all free vertices
  /// Outward triangles (indexing U) of a boundary that lies on the unit
  /// sphere. Their vertices that are not fixed slide on the sphere
  /// (position y/|y|), and the cones (0, a, b, c) join the energy as extra
  /// tets, so no triangle flips on the sphere (orient3d(0,a,b,c) > 0).
  /// Needed when an inversion cannot be repaired with the sphere fixed.
  Eigen::MatrixX3i sphereFaces;
  /// Outward triangles (indexing U) lying on the boundary of the unit cube
  /// [0,1]³. Their vertices that are not fixed slide on the cube's boundary,
  /// cones from (½,½,½) as above. Exclusive with sphereFaces (Error(Usage)).
  Eigen::MatrixX3i cubeFaces;
  /// Per vertex (#V, or empty): bit k set => coordinate k is pinned (to 0 or
  /// 1) on a cube face; 3 bits = a corner, which never moves. Empty: the
  /// coordinates of cube-face vertices that are exactly 0 or 1 are locked.
  /// A cube-face vertex without a locked coordinate is Error(Input).
  std::vector<std::uint8_t> cubeLocks;
  /// Cube: a sliding vertex with one locked coordinate (on a face, not on
  /// an edge or a corner) may cross onto a neighbouring face: it lies at the
  /// point where the ray from (½,½,½) through its unknown position meets the
  /// cube's surface (as y/|y| on the sphere). With locks, a vertex that the
  /// placement put on the wrong side of a cube edge stays there: on spool.off
  /// (--min-dihedral 15) three vertices of one boundary triangle then slid
  /// onto one cube edge from two faces and left their tet flat.
  bool cubeAcrossEdges = false;
  /// Per tet (#T, or empty): the volume each tet should have in the map.
  /// When given, reference tet t is scaled to this volume instead of by the
  /// mapped edge lengths above, so that untangling after the measure-controlled
  /// composition keeps each region's parametric volume (measured: a density-4
  /// region with 20% of the volume fell to 11% when scaled by local ratios).
  Eigen::VectorXd targetVolumes;
  /// Minimise the energy over every free vertex even when nothing is
  /// inverted (one ε round of at most maxLbfgsIterations): moves the map
  /// towards the reference shapes and targetVolumes without ever inverting
  /// a tet (the barrier keeps det J > 0).
  bool relax = false;
  /// When the energy leaves inversions: sweeps of local max-min moves over
  /// the vertices of inverted tets (see untangle.cpp, maxMinSweeps); 0 = none.
  /// A sweep moves its vertices colour by colour (no two vertices of a tet
  /// alike), each colour's at once on all cores; the result does not depend
  /// on the threads. Interior and cube-face vertices move first; with sphereFaces, a second
  /// pass over what that leaves moves the sliding sphere vertices too
  /// (along the tangent plane, projected back onto the sphere). Then, with
  /// localRepairPatches (off by default; parameterize turns it on for the
  /// ball's final untangling) and at most 100 left, joint max-min moves of the
  /// vertices of each tet left (and then of its neighbours' too), for the
  /// configurations where every single move is blocked by another tet of
  /// the vertex's star (untangle.cpp, patchMaxMin). Each pass after the
  /// first is kept only when it leaves fewer inverted tets and flipped
  /// triangles, and the repair as a whole only when it leaves fewer than the
  /// energy did. Measured on the ball's final untangling (parameterize.h,
  /// finalUntangleWork): bunny00 (767k tets) with the patch moves spent its
  /// budget with 6 left, and the repair and two finishing rounds took them
  /// 6 -> 2 -> 1 -> 0 (param 421 s, no morph); without the patch moves the
  /// rounds stopped at 2 and the morph took over. On bunny00's cube map
  /// they turned a valid end (55 -> 2 -> 0) into one that stopped at 1.
  /// (Since the transport's AMG solves, bunny00's ball budget ends with 8371
  /// left: the repair leaves 11 and one finishing round 0; param 443 s.)
  /// Only when at most max(100, localRepairFraction · #tets) tets are left
  /// inverted or boundary triangles flipped (many more: the run fails anyway,
  /// and the moves would take minutes).
  int localRepairSweeps = 100;
  bool localRepairPatches = false;
  double localRepairFraction = 0.02;
  /// While at most this many tets are inverted, the local repair's sweeps
  /// widen to one ring around them at most, not four (0 = always four):
  /// the wider rings move hundreds of vertices a sweep for a few tets and
  /// rarely take one off (untangle.cpp, maxMinSweeps). parameterize sets it
  /// for the final untangling.
  int localRepairFewTets = 0;
  /// Work budget: the run ends (failed, budgetExhausted) after the ε update
  /// in which the energy's tet evaluations (counting each evaluation of a
  /// tet, cones included, once) reach this many while inversions remain;
  /// 0 = no budget. Deterministic, unlike a time limit.
  double maxTetEvaluations = 0;
  /// Once the fewest tets inverted plus boundary triangles flipped, at the
  /// start or at the end of a region, is at most this many, a region that
  /// does not end with at most half that many stops the growing
  /// (UntangleResult::stalled) and what is left goes to the local repair: a
  /// few tets pinched by their neighbours, which wider regions do not repair
  /// either. Measured on bunny00 scaled by 1 + 10⁻⁹ (cube, final
  /// untangling): about 60 tets stayed inverted over four regions, from 7173
  /// to 176486 free vertices and over 300 s, until the budget ran out; and
  /// bunny00 as given, with a tenth fewer as the bar: 26 -> 21 -> 21 over
  /// three regions (3128 to 72221 free vertices, 103 s), which the local
  /// repair and the caller's next phase then took to 0 in 5 s.
  /// 0 = grow until the budget or every vertex is free.
  int stallBelow = 0;
  /// Within a region, once its fewest tets inverted (floating point, after
  /// an ε round) is at most stallBelow: this many ε rounds in a row, none
  /// leaving at most three quarters of the count after the last round that
  /// did, end the region early (it grows, or the stall test above ends the
  /// growing). 0 = every region runs its regionRounds.
  int regionStallRounds = 0;
  /// Cube: interior vertices stay in [0, 1]³ (those outside at the start
  /// are mirrored in through the face): a bijection onto the cube has them
  /// all inside, and nothing else keeps them there (the cones guard the
  /// boundary triangles only), and the local repair cannot move a vertex that
  /// is outside. Measured on bunny00 scaled by 1 + 10⁻⁹ (final untangling):
  /// 55 tets left around interior vertices up to 10⁻³ beyond a face. Off by
  /// default: as the default of the final untangling it changed the maps of
  /// meshes that end valid anyway (retinal's fit error no longer halves from
  /// 8³ to 16³) and kept bracket.step's morph from starting; parameterize
  /// turns it on for its finishing rounds.
  bool keepInteriorInCube = false;
  ProgressCallback progress = {};  ///< called once per ε update; false stops
};

struct UntangleResult {
  Eigen::MatrixX3d U;              ///< #V × 3; fixed vertices unchanged (bitwise)
  int invertedBefore = 0;          ///< exact count of tets with orient3d <= 0, before
  int invertedAfter = 0;           ///< and after
  int outerIterations = 0;         ///< ε updates, summed over regions
  int lbfgsIterations = 0;
  int newtonIterations = 0;
  int freeVertices = 0;            ///< vertices that moved in the last region
  int flippedBoundaryTriangles = 0;  ///< exact, of the options' sphere or cube faces, at the end
  int flippedSphereTriangles = 0;    ///< the same count when sphereFaces was given, else 0 (older callers)
  double minDet = 0;               ///< smallest det J at the end (floating point)
  Status status;                   ///< failure when inversions remain or progress stopped it
  bool stopped = false;            ///< the progress callback stopped it
  double tetEvaluations = 0;       ///< work: tet evaluations of the energy (see maxTetEvaluations)
  /// The energy's minimisation ended by maxTetEvaluations (the local repair
  /// after it may still have fixed all).
  bool budgetExhausted = false;
  /// The regions stopped growing by stallBelow (the local repair after it
  /// may still have fixed all).
  bool stalled = false;
};

/// Untangles U (#V × 3), the image of the reference mesh (reference #V × 3,
/// T #T × 4, positively oriented), keeping the vertices with fixed[i] == true.
/// Throws Error(Input) for mismatched shapes, indices out of range or a
/// reference tet of non-positive volume; Error(Usage) if both sphereFaces and
/// cubeFaces are given.
UntangleResult untangle(const Eigen::MatrixX3d& reference, const Eigen::MatrixX4i& T, const Eigen::MatrixX3d& U,
                        const std::vector<bool>& fixed, const UntangleOptions& options = {});

/// The vertices to hold when untangling a map whose boundary triangles
/// `faces` (indexing U) lie on ∂Ω, a domain star-shaped from `apex`: every
/// vertex of `faces`, except those within `rings` vertex rings (on the
/// boundary surface) of a triangle flipped as seen from apex
/// (orient3d(apex, a, b, c) <= 0), which must slide (pass `faces` as
/// sphereFaces or cubeFaces): with its vertices held, a flipped triangle
/// leaves its tet inverted whatever the interior does. Interior vertices are
/// not held. Returns #U entries.
std::vector<bool> holdBoundaryAwayFromFlips(const Eigen::MatrixX3d& U, const Eigen::MatrixX3i& faces,
                                            const Eigen::Vector3d& apex, int rings);

}  // namespace tet2spline
