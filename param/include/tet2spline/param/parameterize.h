#pragma once
/// The measure-controlled parameterization (design.md, "Measure",
/// "Semi-discrete optimal transport", "Composition and the boundary"; Su et
/// al. 2016, §3–4): the whole param stage from a valid solid to U.
///
///   1. chords split (refine.h), so that no interior edge joins two boundary
///      vertices (else the cube map cannot be valid);
///   2. ball map (ball_map.h): spherical map, harmonic map, untangling;
///   3. measure: per-tet density w_t (regions, a field, voids), vertex masses
///      ν_i = Σ_{t∋i} w_t vol(t)/4 scaled to |Ω|;
///   4. semi-discrete OT (optimal_transport.h) from Ω to the harmonic images
///      (y = U_ball for the ball; y = ½ + ½·U_ball, the inscribed ball, for
///      the cube) with masses ν;
///   5. composition: every vertex moves to the centroid of its Laguerre cell;
///      boundary vertices go onto ∂Ω: on the ball, radially onto the sphere;
///      on the cube, the OT decides which boundary vertices take the 8
///      corners and the 12 edges (the boundary vertex of least power
///      distance |x − y_i|² − ψ_i owns each corner and each point of an
///      edge), the others go to the nearest face. Then untangling with the
///      boundary on ∂Ω (sliding on it where the untangler supports it).
///
/// Without transport (`transport = false`) the result is the harmonic ball
/// map itself (domain must be the ball).

#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>

#include "tet2spline/param/ball_map.h"
#include "tet2spline/param/boundary_smoothing.h"
#include "tet2spline/param/error.h"
#include "tet2spline/param/optimal_transport.h"
#include "tet2spline/param/progress.h"
#include "tet2spline/param/tet_mesh.h"

namespace tet2spline {

enum class ParamDomain { Ball, Cube };

/// Where the density comes from (design.md, "Measure"). Precedence per tet:
/// void regions take `voidDensity` when set, else the field when named, else
/// the region's density, else 1.
struct MeasureOptions {
  std::map<int, double> regionDensity;  ///< region tag -> W (> 0)
  std::string densityField;             ///< per-tet or per-vertex field of the input (values > 0)
  double voidDensity = 0;               ///< > 0: density of void tets; 0: as any other region
};

/// Per-tet densities w_t (#T). Throws Error(Usage) for a region that the
/// mesh does not have, a field that it does not hold, or a density that is
/// not finite and > 0 (Error(Input) when the bad value comes from a field).
Eigen::VectorXd tetDensities(const TetMesh& mesh, const MeasureOptions& measure);

struct ParamOptions {
  ParamDomain domain = ParamDomain::Cube;
  bool transport = true;               ///< false: the harmonic ball map only (ball domain)
  MeasureOptions measure;
  BallMapOptions ballMap;
  /// With the transport, the spherical map gets this many area correction
  /// steps (spherical_map.h, step 4; ballMap.sphere's own value is used
  /// without the transport). Sites from a nearly equiareal boundary start the
  /// transport far closer to its solution: fandisk's cube parameterization
  /// went from 23 to 13 Newton iterations (72 s -> 40 s in all), blobby from
  /// 22 s to 10 s, homer from more than 420 s (still in the transport) to
  /// 163 s (18 iterations); triceratops, with its cap flipped too
  /// (tetrahedralize.h), converges in 38 iterations where it failed at
  /// iteration 2.
  int sphereAreaCorrectionIterations = 30;
  OptimalTransportOptions transportOptions;
  /// Geodesic polytope level for the ball domain (power_diagram.h); < 0:
  /// about two tangent planes per boundary vertex, levels 3 to 6 (clipping
  /// cost grows when a boundary cell meets many planes: part.off, 2.7k
  /// boundary vertices, OT 12.3 s at level 5 against 27.9 s at level 6).
  int ballSubdivisions = -1;
  /// Cube: also put boundary vertices on the 12 edges (the OT decides which,
  /// see above). Off by default: a sphere-like boundary has no mesh edges
  /// along the cube's edges, so triangles that reach across an edge got two
  /// vertices on it and one on a face a hair away; the sliding untangler then
  /// collapsed such pairs (sphere holding a density-4 sphere, 10k tets: 10
  /// tets left inverted, region fraction 0.178 for a target of 0.203; without
  /// edge vertices: 0 inverted, within 0.005). Without them boundary
  /// triangles cut thin wedges off the cube's edges.
  bool cubeEdges = false;
  /// Cube: put the boundary vertex that owns each corner on it. Off by
  /// default for the same reason: face vertices next to a corner slid onto
  /// it (part.off: 3 of 4 remaining inverted tets); without corners part.off
  /// ends with 0. The cube's corners are then cut off by small triangles.
  bool cubeCorners = false;
  /// Cube: the transport's sites are the ball map stretched towards the
  /// cube, x ↦ ½ + ½ x (|x|₂/|x|_∞)^α with α = cubeSiteStretch in [0, 1]
  /// (CLI --site-stretch). α = 0 is the ball inscribed in the cube; the
  /// transport then carries the sites near the sphere out into the cube's
  /// edges and corners. α = 1 puts the sphere onto the cube's faces: all
  /// boundary sites on six planes, a degenerate input for the regular
  /// triangulation (bunny00: triangulation 32.9 s instead of 9.4 s).
  /// A stretch trades measure for speed and smoothness. Measured (cube,
  /// `convert` at the defaults; "misplaced" is half the L1 difference between
  /// the parametric and the target volume over a grid of 8³ cells of the cube,
  /// tets binned by their centroid in U; single runs, and misplaced moves by up
  /// to a third with the sites' last bits, see CubeSites below):
  ///                 α    final untangling  volume ratio p1/p50/p99  misplaced  fit RMS 8³ -> 16³
  ///   bunny00       0    321 s             0.27/1.03/2.71           0.024      0.0102 -> 0.0052 (1.98)
  ///   (767k tets)   0.9   52 s             0.29/1.00/2.26           0.031      0.0086 -> 0.0039 (2.20)
  ///   homer         0     34 s             0.35/1.00/3.65           0.041      (16³) 0.0057
  ///   (181k tets)   0.5   55 s             0.35/1.00/3.26           0.048            0.0057
  ///                 0.9   47 s             0.35/1.00/3.21           0.060            0.0055
  ///   two_material  0     1.5 s            0.64/1.01/2.10           0.021      (8³)  0.0053
  ///   (--density    0.5   0.8 s            0.67/1.06/2.15           0.030            0.0043
  ///    2=4)         0.9   0.9 s            0.64/1.07/2.48           0.039            0.0045
  /// The stretched sites start the transport nearer its solution; bunny00's
  /// composition had as many inverted tets (40k) but its final untangling
  /// finished within its budget (no finishing rounds). The map ends with more
  /// volume along the cube's edges, though (two_material: the tets within
  /// 1/32 of an edge hold 1.58 times their target volume at α = 0.9, 1.23 at
  /// α = 0), homer's untangling got slower, and at 0.9 the solid with a
  /// filled void gave the void 0.0117 of the cube (target 0.0065) and
  /// models/bracket.step's boundary ended 0.093 of the diagonal from its
  /// surface (0.030 at 0). So the default keeps α = 0.
  double cubeSiteStretch = 0.0;
  /// Cube: how the transport's sites come from the ball map (CLI
  /// --cube-sites). Stretch: by cubeSiteStretch above. EqualVolume: by a
  /// volume-preserving map of the ball onto the cube (param/src/cube_map.h:
  /// radius kept, the sphere mapped onto the cube's surface by an equal-area
  /// map; 2% of the way back towards the inscribed ball so that the
  /// sphere's sites are not coplanar), cubeSiteStretch unused. The sites
  /// then hold the ball map's own measure, neither the corners left empty
  /// (α = 0) nor the diagonals diluted (α > 0), and the transport corrects
  /// only the ball map's distortion. Measured (README, medians of five runs
  /// whose sites differ in their last bits; `convert`, Stretch at α = 0 ->
  /// EqualVolume): fit RMS at 16³ blobby 0.00118 -> 0.00095, retinal 0.00262
  /// -> 0.00210, two_material 0.00307 -> 0.00253, but the CAD block with a
  /// void 0.00292 -> 0.00382; misplaced volume retinal 0.037 -> 0.045, block
  /// 0.040 -> 0.042, the others within their spread; the composition's
  /// inversions blobby 529 -> 715, two_material 471 -> 817. bunny00 (one
  /// run): transport 27 -> 19 s, fit RMS 8³ -> 16³ 0.00858 -> 0.00384 (2.23
  /// times; 1.98 at α = 0), final untangling as slow (305 s). A trade, so
  /// not the default for every input.
  /// Auto (the default): EqualVolume when the outer boundary is smooth and
  /// curved: the 99th percentile of the angle between adjacent boundary
  /// triangles' normals (topology.h normalAngleQuantile) below
  /// smoothBoundaryDegrees, no creases or sharp tips, and less than
  /// planarBoundaryShare of its area in planar faces (topology.h
  /// planarShare), no large planar faces.
  /// Stretch otherwise (creases, tips, CAD solids, filleted or not), and
  /// Stretch when cubeSiteStretch > 0 (a stretch asked for). On the smooth,
  /// curved inputs the equal-volume sites fit better (measured again,
  /// Stretch -> EqualVolume, fit RMS 8³ -> 16³: blobby 0.00275 -> 0.00118
  /// (2.33 times) against 0.00211 -> 0.00097 (2.17), retinal 0.00537 ->
  /// 0.00240 (2.24) against 0.00454 -> 0.00210 (2.16), bunny00 0.0102 ->
  /// 0.00517 (1.97) against 0.00859 -> 0.00395 (2.17), whose total also
  /// went 311 s (median of three draws) -> 169 s (median of three)). On the
  /// CAD solids they fit worse: the block with a void above, and
  /// models/bracket.step (filleted everywhere, so smooth: normal angle p99
  /// 13°, but 0.69 planar) ended 0.10 of the diagonal from its surface
  /// instead of 0.03. ParamResult::Figures says which sites ran.
  enum class CubeSites { Auto, Stretch, EqualVolume };
  CubeSites cubeSites = CubeSites::Auto;
  /// Cube, CubeSites::Auto: the largest 99th percentile of the normal angle
  /// (degrees; edges inside planar faces left out) at which the boundary
  /// counts as smooth. The libcgal-demo meshes, meshed as the command line
  /// meshes them, fall into two groups: 16–25° (bunny00, blobby, retinal)
  /// and 42° or more (homer, blob-closed, fandisk, triceratops, part,
  /// spool, hand); tests/param/parameterize_realdata_slow_test.cpp.
  double smoothBoundaryDegrees = 30.0;
  /// Cube, CubeSites::Auto: the share of the boundary's area in planar
  /// faces (topology.h planarShare: within 0.1° of coplanar, patches of at
  /// least 1% of the area) from which it counts as not curved. Measured:
  /// bunny00, blobby, retinal 0; bracket.step 0.69, block_with_void.step
  /// 0.64 (both filleted, normal angle p99 13–14°); part 0.68, fandisk 0.43.
  double planarBoundaryShare = 0.5;
  /// One OT site per region where regions meet (parameterize.cpp buildSites):
  /// Off, On, or Auto (default): on when the density jumps somewhere (a
  /// vertex whose tets have different densities), so volume-preserving runs
  /// keep one site per vertex.
  /// Measured on a sphere holding a density-4 sphere (2.5k tets, ball):
  /// region fraction 0.193 instead of 0.165 (target 0.203) straight after the
  /// composition, but 36-46 inverted tets instead of 0-10; after the measure
  /// relaxation both give 0.1975. On models/two_material.off (--density 2=4,
  /// cube) the relaxation alone leaves region 2 at 0.1431–0.1454 of the cube
  /// (target 0.1485; the spread is rounding in the transport's last digits
  /// amplified by the untangling; 1000 or 3000 relaxation iterations, or
  /// sliding boundary vertices, give 0.1446–0.1457), with interface sites
  /// 0.1499.
  enum class InterfaceSites { Off, On, Auto };
  InterfaceSites interfaceSites = InterfaceSites::Auto;
  /// The final untangling, first phase: the boundary held except near the
  /// triangles the placement flipped (untangle.h, holdBoundaryAwayFromFlips).
  /// After the composition the inversions are many (~8% of the tets of
  /// part.off) but shallow, so a one-ring region and short L-BFGS runs do it
  /// fastest (part.off, ball: 3 rings/100 iterations 22.7 s, every vertex
  /// free 24.5 s, 1 ring/30 iterations 11.3 s, with the same volume-ratio
  /// percentiles), and a region that fails is grown after 6 rounds: where
  /// the held boundary makes it hopeless, the sliding phase that follows
  /// (the UntangleOptions defaults) does it (final untangling with 16
  /// rounds, then 6: homer cube 91 -> 61 s, fandisk ball 16 -> 4.6 s).
  UntangleOptions untangle = [] {
    UntangleOptions u;
    u.rings = 1;
    u.maxLbfgsIterations = 30;
    u.regionRounds = 6;
    return u;
  }();
  /// L-BFGS iterations of the measure relaxation after untangling (untangle.h
  /// `relax` with per-tet target volumes, boundary fixed), around density
  /// jumps only (relaxRings); 0 skips it. Volume-preserving runs have no
  /// jump and skip it.
  /// The vertex -> Laguerre-centroid composition smears the measure over the
  /// cells at a density jump: on the sphere holding a density-4 sphere (2.5k
  /// tets, ball) the inner region got 0.165 of the ball instead of 0.203;
  /// relaxing towards the target volumes gives 0.130 at θ = 0.5 (shape term
  /// wins), 0.189 at θ = 0.95, 0.1975 at θ = 0.995 (300 iterations), 0.1985
  /// at θ = 0.999 (1000); at 10k tets 0.1997.
  int relaxIterations = 300;
  int relaxRings = 6;                  ///< vertices within this many rings of a density jump move (3 rings: 0.1968, 6: 0.1997, all: 0.1997)
  double relaxTheta = 0.999;           ///< weight of the volume term in the relaxation (untangle.h θ)
  /// Last step with transport: tangential smoothing of the boundary
  /// (boundary_smoothing.h; its `shape` follows `domain`), which removes the
  /// noise the composition leaves along ∂Ω; sweeps = 0 skips it.
  BoundarySmoothingOptions boundarySmoothing;
  /// When the final untangling leaves tets inverted: move the bijective ball
  /// map (stretched onto the cube for the cube) towards the untangler's
  /// result behind a barrier (barrier_morph.h), so the map is bijective
  /// whatever the composition folded; report keys param.morph.*. Measured:
  /// hand.off, about 2950 tets left on the cube and 2195 on the ball, ends
  /// with none (volume ratio p1/p50/p99 0.22/1.09/269 on the cube,
  /// 0.26/1.11/122 on the ball); spool.off (6 left on the cube) with none,
  /// p50 0.75. With finalUntangleWork (3069 and 8 left when it is spent):
  /// hand cube 0.22/1.09/252, spool cube 0.049/0.75/4.27. The tets with the
  /// largest ratios touch the boundary and are as large in the untangler's
  /// result. hand's cube spline then fitted with no
  /// negative Gauss point (RMS 0.0060 of the diagonal, boundary Hausdorff
  /// 0.028). (Those hand cube figures are from an earlier state; measured
  /// again after the transport learned to carry ψ in two doubles
  /// (optimal_transport.h): p1/p50/p99 0.24/1.07/236, 3448 tets inverted
  /// by the composition, fit RMS 0.0060, Hausdorff 0.028; with
  /// --min-dihedral 15 the morph gives p1/p50/p99 0.34/1.06/59.) On the
  /// cube the stretch's folds are untangled first against the ball map's
  /// own tet shapes, then against the input's (parameterize.cpp,
  /// MorphStartShapes): models/bracket.step (30k tets folded by the
  /// composition, 10k left) is valid only through the first, p1/p50/p99
  /// 0.16/1.14/14.2.
  bool morphWhenTangled = true;
  /// With morphWhenTangled (and a sphere map with no flipped triangle, which
  /// the morph needs): the final untangling's phases together end after
  /// this many evaluations of the energy over the whole mesh (untangle.h
  /// maxTetEvaluations, in units of #tets), and what is left inverted goes
  /// to the morph; 0 = no budget. Measured (cube, all phases): homer 1992,
  /// triceratops 620, part 533, retinal 458, fandisk 330, blobby 103
  /// (ball: at most 647); on the failing ones spool's ball untangling
  /// spent 4245 and bunny00's cube untangling ran 14 minutes (about 9·10⁶
  /// tet evaluations per second on 2 cores) without finishing. With it,
  /// bunny00 on the ball (767k tets) spends it in 779 s with 1 tet left
  /// after the local repair, and the morph makes the map valid in 459 s
  /// (rms 0.044 target edges; 1486 s in all, the cores shared). On the
  /// cube, a budget spent with at most max(100, 2% of the tets) tets and
  /// boundary triangles left gets more ε rounds across cube edges, each
  /// with the local repair, while each leaves fewer (at most 8,
  /// parameterize.cpp; report param.finishing_rounds): bunny00's cube map,
  /// 9 tets and 2 triangles left after 298 s, was valid after one, without
  /// the morph (whose cube start fails there); with the transport's later
  /// last bits, 53 left after the local repair, two rounds (55 -> 2 -> 0,
  /// 5 s) make it valid, where one left 2 and the morph took 931 s. The
  /// ball gets the same rounds (without the edges), now that the local
  /// repair also slides sphere vertices and moves patches jointly
  /// (untangle.h localRepairSweeps): bunny00 on the ball spends its budget
  /// with 6 left, 2 after the repair, and two rounds take them to 0
  /// (param 421 s, no morph). spool on the ball still ends with 3 tets the
  /// rounds cannot repair, and the morph takes them.
  double finalUntangleWork = 3000;
  bool splitChords = true;             ///< step 1 (required for the cube)
  ProgressCallback progress = {};      ///< fraction over the whole stage; false stops
};

struct RegionFigures {
  int id = 0;
  bool isVoid = false;
  double physicalVolume = 0;
  double density = 1;                  ///< mean w over the region (by volume)
  double targetVolumeFraction = 0;     ///< Σ w vol over the region / Σ w vol
  double achievedVolumeFraction = 0;   ///< parametric volume of the region / parametric volume of all
};

struct ParamResult {
  /// Percentiles and extremes of a per-tet volume ratio.
  struct VolumeRatios {
    double p1 = 0, p50 = 0, p99 = 0, min = 0, max = 0;
  };
  TetMesh mesh;                        ///< the input after step 1 (more vertices and tets if chords were split)
  Eigen::MatrixX3d U;                  ///< #V × 3: parameter of every vertex of `mesh`
  Eigen::MatrixX3d ballU;              ///< #V × 3: the harmonic ball map
  Eigen::VectorXi boundaryVertices;    ///< of the outer shell, ascending
  Eigen::MatrixX3i boundaryFaces;      ///< outward triangles of the outer shell
  Eigen::VectorXd targetVolume;        ///< per tet: |Ω| w_t vol_t / Σ w vol
  Eigen::VectorXd parametricVolume;    ///< per tet: signed volume of the tet in U
  int chordsSplit = 0;
  double domainVolume = 0;             ///< |Ω| as represented (ball: the polytope)
  std::string domainRepresentation;    ///< how Ω is represented, and its volume error
  std::vector<std::string> warnings;   ///< what the user should know about a result that is valid

  BallMapResult::Sphere sphere;
  BallMapResult::Ball ball;
  double ballBoundaryMaxDistance = 0;
  /// The transport's start against the measure: per tet, its share of the
  /// ball map's volume over its share of the target volume (report key
  /// ball.volume_ratio; 1 everywhere would leave the transport nothing to
  /// move). Values far below 1 are cells the transport has to open from
  /// almost nothing: bunny00's ears (23.6k tets below 10⁻³ before the
  /// ball map's untangling) are why its transport starts with steps of 2⁻¹³.
  VolumeRatios ballVolumeRatio;
  struct Transport {
    bool ran = false;
    int iterations = 0;
    double maxRelativeMassError = 0;
    std::vector<double> stepSizes;
    int mergedPoints = 0;
    /// Ended just above the tolerance, every fallback's search failed
    /// (optimal_transport.h, stallAcceptFactor); a warning says so.
    bool stalledAboveTolerance = false;
    int solverSwitches = 0;             ///< CG tightenings, switches to the AMG, to CHOLMOD and to the relative merit (optimal_transport.h)
    int amgIterations = 0;              ///< Newton iterations whose system was solved with the AMG cycle
    double triangulationSeconds = 0, clippingSeconds = 0, assemblySeconds = 0, linearSolveSeconds = 0;
    std::string linearSolver;
  } ot;
  struct Figures {
    int invertedTets = 0;              ///< exact, at the end
    int invertedTetsBeforeUntangling = 0;
    double boundaryMaxDistance = 0;    ///< largest distance of a boundary vertex to ∂Ω
    VolumeRatios volumeRatio;          ///< parametric / target, per tet
    /// The measure at the scale of spline elements: misplacedVolumeFraction
    /// over 8³ cells of Ω's bounding box, with the target volumes.
    double misplacedVolume = 0;
    int cornerVertices = 0, edgeVertices = 0;  ///< cube: boundary vertices put on corners / edges
    /// Cube with transport: the sites the transport started from (never Auto)
    /// and the outer boundary's 99th-percentile normal angle (degrees) and
    /// planar share that chose them under CubeSites::Auto.
    ParamOptions::CubeSites cubeSites = ParamOptions::CubeSites::Stretch;
    double boundaryNormalAngleP99 = 0;
    double boundaryPlanarShare = 0;    ///< planarShare of the outer boundary (see planarBoundaryShare)
    int flippedBoundaryTriangles = 0;  ///< exact, boundary triangles flipped on ∂Ω (seen from its centre)
    int finishingRounds = 0;           ///< ε rounds after the final untangling's budget was spent or its regions stalled (and after edge splits), each leaving fewer
    int splitEdges = 0;                ///< edges split for tets the final untangling's rounds left inverted (new vertices)
    bool morphed = false;              ///< the final map is the ball map morphed towards the untangler's result
    double morphDistance = 0;          ///< then: rms of |U − target| per vertex, in target edges (barrier_morph.h)
    double morphMaxDistance = 0;       ///< and its largest
    long boundarySmoothingMoves = 0;   ///< boundary vertex moves of the smoothing (all sweeps)
    long interiorSmoothingMoves = 0;   ///< interior vertex moves of the smoothing (all sweeps)
    long boundarySmoothingRefused = 0; ///< its moves dropped to keep every tet positive
    double boundarySmoothingRms = 0;   ///< rms displacement of the boundary vertices by it
  } param;
  std::vector<RegionFigures> regions;
  struct Timings {
    double refine = 0, sphere = 0, harmonic = 0, untangle = 0, measure = 0, transport = 0, composition = 0,
           finalUntangle = 0, morph = 0, relax = 0, boundarySmoothing = 0, total = 0;
  } timings;
  Status status;                       ///< failure when inversions remain, OT did not converge or it was stopped
};

/// Runs the stage on a valid solid (topology.h requireValidSolid). Throws
/// Error(Usage) for bad options (unknown region, ball-less transport-free cube),
/// Error(Topology) from the ball map; numerical trouble is a failed status.
ParamResult parameterize(const TetMesh& mesh, const ParamOptions& options = {});

/// How far the map is from its measure at a coarser scale than the tets':
/// the box [lo, hi] split into cells³ equal cells, each tet counted in the
/// cell holding its centroid in U, half the sum over the cells of
/// |Σ parametric volume − Σ target volume|, divided by Σ target volume.
/// 0 when every cell gets its target; the fraction of the measure that sits
/// in the wrong cell otherwise (the per-tet volume ratios do not show a
/// misplacement spread over many tets). Throws Error(Input) for mismatched
/// sizes and cells < 1.
double misplacedVolumeFraction(const Eigen::MatrixX3d& U, const Eigen::MatrixX4i& T, const Eigen::VectorXd& targetVolumes,
                               const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int cells);

}  // namespace tet2spline
