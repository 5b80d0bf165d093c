// Laws of clipped power diagrams: the cells tile Ω, facets are shared, simple
// configurations have known cells, hidden and coincident sites do not crash.
#include "tet2spline/param/power_diagram.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

#include "tet2spline/param/error.h"

using namespace tet2spline;

namespace {

Eigen::MatrixX3d randomPoints(int n, unsigned seed, double lo = 0, double hi = 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  Eigen::MatrixX3d p(n, 3);
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) p(i, c) = u(rng);
  return p;
}

Eigen::MatrixX3d randomPointsInBall(int n, unsigned seed, double radius) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::MatrixX3d p(n, 3);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d x;
    do x = Eigen::Vector3d(u(rng), u(rng), u(rng));
    while (x.squaredNorm() > 1);
    p.row(i) = radius * x.transpose();
  }
  return p;
}

// Area a_ji of the facet of j shared with i (0 when i is not a neighbour of j).
double facetArea(const PowerDiagram& pd, int j, int i) {
  for (int k = pd.neighbourStart[j]; k < pd.neighbourStart[j + 1]; ++k)
    if (pd.neighbour[k] == i) return pd.facetArea[k];
  return 0;
}

void expectTiling(const PowerDiagram& pd, const Domain& domain, double relTol) {
  EXPECT_NEAR(pd.volumes.sum(), domain.volume(), relTol * domain.volume());
  for (int i = 0; i < pd.volumes.size(); ++i) {
    EXPECT_GE(pd.volumes[i], 0);
    if (pd.volumes[i] > 0) {
      EXPECT_TRUE(domain.contains(pd.centroids.row(i).transpose(), 1e-12)) << "cell " << i;
    }
  }
  double maxArea = 0;
  for (double a : pd.facetArea) maxArea = std::max(maxArea, a);
  for (int i = 0; i + 1 < static_cast<int>(pd.neighbourStart.size()); ++i)
    for (int k = pd.neighbourStart[i]; k < pd.neighbourStart[i + 1]; ++k)
      EXPECT_NEAR(pd.facetArea[k], facetArea(pd, pd.neighbour[k], i), 1e-11 * maxArea) << i << " " << pd.neighbour[k];
}

}  // namespace

TEST(PowerDiagram, CubeCellsTileTheCubeWithSymmetricFacets) {
  const Eigen::MatrixX3d y = randomPoints(3000, 1);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(0, 1e-3);
  Eigen::VectorXd psi(y.rows());
  for (auto& w : psi) w = u(rng);
  const PowerDiagram pd = computePowerDiagram(y, psi, Domain::unitCube());
  expectTiling(pd, Domain::unitCube(), 1e-12);
}

TEST(PowerDiagram, BallCellsTileTheBallPolytope) {
  const Domain ball = Domain::unitBall();
  const Eigen::MatrixX3d y = randomPointsInBall(3000, 3, 1.0);
  const PowerDiagram pd = computePowerDiagram(y, Eigen::VectorXd::Zero(y.rows()), ball);
  expectTiling(pd, ball, 1e-12);
}

// The dual measurement of inner cells (power centres around each edge) gives
// the clipper's volumes, centroids and facet areas, on both domains, with
// weights spread enough that some sites are hidden and cells differ in size.
void expectDualMatchesClipping(const Eigen::MatrixX3d& y, const Eigen::VectorXd& psi, const Domain& domain) {
  const PowerDiagram dual = computePowerDiagram(y, psi, domain, CellMeasure::DualWhereInside);
  const PowerDiagram clip = computePowerDiagram(y, psi, domain, CellMeasure::ClipAll);
  const int n = static_cast<int>(y.rows());
  EXPECT_EQ(clip.clippedCells, n - clip.hiddenSites);
  EXPECT_LT(dual.clippedCells, n / 2) << "the dual measured too few cells for the test to mean anything";
  ASSERT_EQ(dual.neighbour, clip.neighbour);
  const double meanVolume = domain.volume() / n;
  for (int i = 0; i < n; ++i) {
    EXPECT_NEAR(dual.volumes[i], clip.volumes[i], 1e-10 * meanVolume) << i;
    EXPECT_LT((dual.centroids.row(i) - clip.centroids.row(i)).norm(), 1e-10) << i;
  }
  const double meanArea = std::pow(meanVolume, 2.0 / 3.0);
  for (std::size_t k = 0; k < dual.facetArea.size(); ++k)
    EXPECT_NEAR(dual.facetArea[k], clip.facetArea[k], 1e-10 * meanArea) << k;
  expectTiling(dual, domain, 1e-12);
}

TEST(PowerDiagram, DualMeasureOfInnerCellsMatchesClipping) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0, 2e-3);
  Eigen::MatrixX3d y = randomPoints(4000, 10);
  Eigen::VectorXd psi(y.rows());
  for (auto& w : psi) w = u(rng);
  expectDualMatchesClipping(y, psi, Domain::unitCube());
  y = randomPointsInBall(4000, 12, 0.9);
  for (auto& w : psi) w = u(rng);
  expectDualMatchesClipping(y, psi, Domain::unitBall(4));
}

TEST(PowerDiagram, BallPolytopeContainsTheSphereAndApproximatesItsVolume) {
  const Domain ball = Domain::unitBall();
  EXPECT_EQ(ball.planeNormals().rows(), 40962);
  EXPECT_GT(ball.volume(), 4 * M_PI / 3);
  EXPECT_LT(ball.volume() / (4 * M_PI / 3) - 1, 1e-4);
  const Eigen::MatrixX3d dirs = randomPoints(2000, 4, -1, 1);
  for (int i = 0; i < dirs.rows(); ++i) {
    const Eigen::Vector3d x = dirs.row(i).normalized();
    EXPECT_TRUE(ball.contains(x)) << x.transpose();
    EXPECT_FALSE(ball.contains(1.001 * x));
    // The hill-climb finds the brute-force maximiser.
    Eigen::Index best;
    const double bestDot = (ball.planeNormals() * x).maxCoeff(&best);
    EXPECT_DOUBLE_EQ(ball.planeNormals().row(ball.mostExposedPlane(x)).dot(x), bestDot);
  }
}

TEST(PowerDiagram, SingleSiteOwnsTheWholeDomain) {
  Eigen::MatrixX3d y(1, 3);
  y << 0.3, 0.6, 0.2;
  PowerDiagram pd = computePowerDiagram(y, Eigen::VectorXd::Zero(1), Domain::unitCube());
  EXPECT_NEAR(pd.volumes[0], 1, 1e-14);
  EXPECT_LT((pd.centroids.row(0) - Eigen::RowVector3d(0.5, 0.5, 0.5)).norm(), 1e-14);

  const Domain ball = Domain::unitBall(3);  // 642 planes: the single cell meets them all
  pd = computePowerDiagram(y, Eigen::VectorXd::Zero(1), ball);
  EXPECT_NEAR(pd.volumes[0], ball.volume(), 1e-12 * ball.volume());
  EXPECT_LT(pd.centroids.row(0).norm(), 1e-12);
}

TEST(PowerDiagram, TwoByTwoByTwoGridGivesEqualOctants) {
  Eigen::MatrixX3d y(8, 3);
  for (int k = 0; k < 8; ++k) y.row(k) << (k & 1 ? 0.75 : 0.25), (k & 2 ? 0.75 : 0.25), (k & 4 ? 0.75 : 0.25);
  const PowerDiagram pd = computePowerDiagram(y, Eigen::VectorXd::Zero(8), Domain::unitCube());
  for (int k = 0; k < 8; ++k) {
    EXPECT_NEAR(pd.volumes[k], 0.125, 1e-15);
    EXPECT_LT((pd.centroids.row(k) - y.row(k)).norm(), 1e-15);
    for (int l = 0; l < 8; ++l) {
      if (l == k) continue;
      const int differing = __builtin_popcount(k ^ l);
      EXPECT_NEAR(facetArea(pd, k, l), differing == 1 ? 0.25 : 0.0, 1e-15) << k << " " << l;
    }
  }
}

TEST(PowerDiagram, TwoSitesSplitAtTheRadicalPlane) {
  Eigen::MatrixX3d y(2, 3);
  y << 0.25, 0.5, 0.5, 0.75, 0.5, 0.5;
  Eigen::VectorXd psi(2);
  psi << 0.1, 0.0;  // plane at x = 0.5 + (ψ_0 − ψ_1)/(2·0.5)
  const PowerDiagram pd = computePowerDiagram(y, psi, Domain::unitCube());
  EXPECT_NEAR(pd.volumes[0], 0.6, 1e-15);
  EXPECT_NEAR(pd.volumes[1], 0.4, 1e-15);
  EXPECT_NEAR(pd.centroids(0, 0), 0.3, 1e-15);
  EXPECT_NEAR(pd.centroids(1, 0), 0.8, 1e-15);
  EXPECT_NEAR(facetArea(pd, 0, 1), 1.0, 1e-15);
}

TEST(PowerDiagram, AddingAConstantToTheWeightsChangesNothing) {
  const Eigen::MatrixX3d y = randomPoints(500, 5);
  Eigen::VectorXd psi = 1e-3 * Eigen::VectorXd::Random(500);
  const PowerDiagram a = computePowerDiagram(y, psi, Domain::unitCube());
  const PowerDiagram b = computePowerDiagram(y, psi.array() + 3.7, Domain::unitCube());
  EXPECT_LT((a.volumes - b.volumes).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((a.centroids - b.centroids).cwiseAbs().maxCoeff(), 1e-10);
}

// ψ = weights + weightTails: the tails keep the precision a double ψ lacks.
// A constant K = 10⁶ added to small weights rounds each head to 1.2e-10
// (what happens to a double ψ of order 0.1 at the scale of 10⁻¹³ cells);
// with the exact remainders as tails the diagram is that of the unshifted
// weights, on both measures and both orders, and without them it is not.
TEST(PowerDiagram, WeightTailsCarryThePrecisionTheWeightsLose) {
  const Eigen::MatrixX3d y = randomPoints(500, 21);
  const Eigen::VectorXd psi = 1e-3 * Eigen::VectorXd::Random(500);
  const double shift = 1e6;
  Eigen::VectorXd heads(500), tails(500);
  for (int i = 0; i < 500; ++i) {
    heads[i] = psi[i] + shift;
    tails[i] = psi[i] - (heads[i] - shift);  // exact: heads[i] - shift is exact (Sterbenz)
  }
  ASSERT_GT(tails.cwiseAbs().maxCoeff(), 0) << "the shift must round the weights";
  const double meanVolume = 1.0 / 500;
  for (const CellMeasure measure : {CellMeasure::DualWhereInside, CellMeasure::ClipAll}) {
    const PowerDiagram reference = computePowerDiagram(y, psi, Domain::unitCube(), measure);
    for (const bool presorted : {false, true}) {
      const PowerDiagram withTails = computePowerDiagram(y, heads, Domain::unitCube(), measure, presorted, &tails);
      EXPECT_LT((withTails.volumes - reference.volumes).cwiseAbs().maxCoeff(), 1e-12 * meanVolume);
      EXPECT_LT((withTails.centroids - reference.centroids).cwiseAbs().maxCoeff(), 1e-12);
    }
    const PowerDiagram headsOnly = computePowerDiagram(y, heads, Domain::unitCube(), measure);
    EXPECT_GT((headsOnly.volumes - reference.volumes).cwiseAbs().maxCoeff(), 1e-10 * meanVolume);
  }
  const Eigen::VectorXd shortTails = Eigen::VectorXd::Zero(499);
  EXPECT_THROW(computePowerDiagram(y, heads, Domain::unitCube(), CellMeasure::DualWhereInside, false, &shortTails),
               Error);
  Eigen::VectorXd badTails = tails;
  badTails[7] = std::nan("");
  try {
    computePowerDiagram(y, heads, Domain::unitCube(), CellMeasure::DualWhereInside, false, &badTails);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Input);
    EXPECT_NE(std::string(e.what()).find("point 7"), std::string::npos) << e.what();
  }
}

TEST(PowerDiagram, HiddenSitesHaveEmptyCells) {
  Eigen::MatrixX3d y = randomPoints(200, 6);
  Eigen::VectorXd psi = Eigen::VectorXd::Zero(200);
  y.row(7) = 0.5 * (y.row(3) + y.row(4));
  psi[7] = -10;  // far below its neighbours: no cell at all
  const PowerDiagram pd = computePowerDiagram(y, psi, Domain::unitCube());
  EXPECT_GE(pd.hiddenSites, 1);
  EXPECT_EQ(pd.volumes[7], 0);
  expectTiling(pd, Domain::unitCube(), 1e-12);
}

TEST(PowerDiagram, CoincidentSitesDoNotCrash) {
  Eigen::MatrixX3d y = randomPoints(100, 7);
  y.row(10) = y.row(20);
  y.row(30) = y.row(20);
  Eigen::VectorXd psi = Eigen::VectorXd::Zero(100);
  PowerDiagram pd = computePowerDiagram(y, psi, Domain::unitCube());
  EXPECT_EQ(pd.hiddenSites, 2);
  EXPECT_EQ((pd.volumes[10] > 0) + (pd.volumes[20] > 0) + (pd.volumes[30] > 0), 1);
  expectTiling(pd, Domain::unitCube(), 1e-12);
  psi[30] = 1e-3;  // the heavier one owns the cell
  pd = computePowerDiagram(y, psi, Domain::unitCube());
  EXPECT_GT(pd.volumes[30], 0);
  EXPECT_EQ(pd.volumes[10], 0);
  EXPECT_EQ(pd.volumes[20], 0);
}

TEST(PowerDiagram, SitesOutsideTheDomain) {
  Eigen::MatrixX3d y = randomPoints(100, 8);
  y.row(0) << 5, 0.5, 0.5;  // its cell misses the cube
  const PowerDiagram pd = computePowerDiagram(y, Eigen::VectorXd::Zero(100), Domain::unitCube());
  EXPECT_EQ(pd.volumes[0], 0);
  expectTiling(pd, Domain::unitCube(), 1e-12);
}

TEST(PowerDiagram, BadInputThrows) {
  const Eigen::MatrixX3d y = randomPoints(10, 9);
  try {
    computePowerDiagram(y, Eigen::VectorXd::Zero(9), Domain::unitCube());
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Usage);
    EXPECT_NE(std::string(e.what()).find("computePowerDiagram"), std::string::npos);
  }
  Eigen::MatrixX3d bad = y;
  bad(3, 1) = std::nan("");
  try {
    computePowerDiagram(bad, Eigen::VectorXd::Zero(10), Domain::unitCube());
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Input);
    EXPECT_NE(std::string(e.what()).find("point 3"), std::string::npos);
  }
  EXPECT_THROW(Domain::unitBall(9), Error);
}

// ---------------------------------------------------------------------------
// Seeded diagrams: the seed's regular triangulation repaired by flips.

namespace {

// The seeded and the unseeded diagram are the same: same tets in the same
// (canonical) order, bitwise the same measurements.
void expectSameDiagram(const PowerDiagram& a, const PowerDiagram& b) {
  EXPECT_EQ(a.tetVertex, b.tetVertex);
  EXPECT_EQ(a.tetNeighbour, b.tetNeighbour);
  EXPECT_EQ(a.hiddenSites, b.hiddenSites);
  EXPECT_EQ(a.neighbour, b.neighbour);
  EXPECT_EQ(a.facetArea, b.facetArea);
  EXPECT_TRUE(a.volumes == b.volumes);
  EXPECT_TRUE(a.centroids == b.centroids);
}

// Every interior facet of the tets is locally regular: the opposite vertex
// has positive power distance to the tet's orthogonal sphere (checked in
// long double, with a margin the tests' weights keep clear of).
int nonRegularFacets(const PowerDiagram& pd, const Eigen::MatrixX3d& y, const Eigen::VectorXd& psi) {
  int bad = 0;
  for (std::size_t t = 0; t < pd.tetVertex.size(); ++t)
    for (int q = 0; q < 4; ++q) {
      const int u = pd.tetNeighbour[t][q];
      if (u < 0) continue;
      int b = -1;
      for (int s = 0; s < 4; ++s)
        if (pd.tetNeighbour[u][s] == static_cast<int>(t)) b = pd.tetVertex[u][s];
      // Orthogonal centre z of the tet: 2 (y_k − y_0)·z = |y_k|² − ψ_k − |y_0|² + ψ_0.
      const auto& v = pd.tetVertex[t];
      Eigen::Matrix3d A;
      Eigen::Vector3d r;
      for (int k = 1; k < 4; ++k) {
        A.row(k - 1) = 2 * (y.row(v[k]) - y.row(v[0]));
        r[k - 1] = y.row(v[k]).squaredNorm() - psi[v[k]] - y.row(v[0]).squaredNorm() + psi[v[0]];
      }
      const Eigen::Vector3d z = A.partialPivLu().solve(r);
      const double power0 = (z - y.row(v[0]).transpose()).squaredNorm() - psi[v[0]];
      const double powerB = (z - y.row(b).transpose()).squaredNorm() - psi[b];
      bad += powerB < power0 - 1e-9;
    }
  return bad;
}

Eigen::VectorXd randomWeights(int n, unsigned seed, double scale) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, scale);
  Eigen::VectorXd psi(n);
  for (auto& w : psi) w = u(rng);
  return psi;
}

}  // namespace

TEST(PowerDiagram, CgalsTriangulationIsLocallyRegularSoItsOwnSeedNeedsNoFlip) {
  const Eigen::MatrixX3d y = randomPointsInBall(3000, 21, 0.45).rowwise() + Eigen::RowVector3d(0.5, 0.5, 0.5);
  const Eigen::VectorXd psi = randomWeights(3000, 22, 3e-5);
  const PowerDiagram pd = computePowerDiagram(y, psi, Domain::unitCube());
  ASSERT_EQ(pd.hiddenSites, 0);
  EXPECT_FALSE(pd.repaired);
  EXPECT_EQ(nonRegularFacets(pd, y, psi), 0);
  const PowerDiagram again = computePowerDiagram(y, psi, Domain::unitCube(), CellMeasure::DualWhereInside, false,
                                                 nullptr, &pd);
  EXPECT_TRUE(again.repaired);
  EXPECT_EQ(again.flips, 0);
  expectSameDiagram(again, pd);
}

TEST(PowerDiagram, RepairedTriangulationIsTheRegularOneCgalBuilds) {
  // Sites of an OT problem (a ball in the cube), weights changed by steps
  // from a few flips to thousands; presorted and in input order.
  const int n = 4000;
  Eigen::MatrixX3d y = randomPointsInBall(n, 23, 0.45).rowwise() + Eigen::RowVector3d(0.5, 0.5, 0.5);
  const Eigen::VectorXd psi0 = randomWeights(n, 24, 2e-4);
  for (bool presorted : {false, true}) {
    if (presorted) {
      const std::vector<int> order = spatialOrder(y);
      Eigen::MatrixX3d sorted(n, 3);
      for (int r = 0; r < n; ++r) sorted.row(r) = y.row(order[r]);
      y = sorted;
    }
    const PowerDiagram seed = computePowerDiagram(y, psi0, Domain::unitCube(), CellMeasure::DualWhereInside, presorted);
    long lastFlips = -1;
    for (double scale : {1e-7, 1e-6, 1e-5, 1e-4}) {
      const Eigen::VectorXd psi = psi0 + randomWeights(n, 25, scale) - Eigen::VectorXd::Constant(n, scale / 2);
      const PowerDiagram fresh = computePowerDiagram(y, psi, Domain::unitCube(), CellMeasure::DualWhereInside, presorted);
      const PowerDiagram repaired =
          computePowerDiagram(y, psi, Domain::unitCube(), CellMeasure::DualWhereInside, presorted, nullptr, &seed);
      ASSERT_EQ(fresh.hiddenSites, 0) << scale;
      EXPECT_TRUE(repaired.repaired) << scale;
      EXPECT_GT(repaired.flips, lastFlips) << scale;
      lastFlips = repaired.flips;
      expectSameDiagram(repaired, fresh);
      EXPECT_EQ(nonRegularFacets(repaired, y, psi), 0) << scale;
      expectTiling(repaired, Domain::unitCube(), 1e-12);
    }
    EXPECT_GT(lastFlips, 100);
  }
}

TEST(PowerDiagram, FailedRepairsAreRejectedOnlyOverASmallCellAndOtherwiseGoInParts) {
  // Smooth weight changes (like the transport's Newton steps) of growing
  // size: small ones are repaired in one go, larger ones exceed the flip
  // limit (a quarter of the tets) and go in 2 or 4 parts, and those that
  // hide sites are rejected without a triangulation from scratch. Each
  // outcome must agree with CGAL's triangulation from scratch.
  const int n = 20000;
  const Eigen::MatrixX3d y0 = randomPointsInBall(n, 23, 0.45).rowwise() + Eigen::RowVector3d(0.5, 0.5, 0.5);
  const std::vector<int> order = spatialOrder(y0);
  Eigen::MatrixX3d y(n, 3);
  for (int r = 0; r < n; ++r) y.row(r) = y0.row(order[r]);
  const Eigen::VectorXd psi0 = randomWeights(n, 24, 2e-5);
  const PowerDiagram seed = computePowerDiagram(y, psi0, Domain::unitCube(), CellMeasure::DualWhereInside, true);
  ASSERT_EQ(seed.hiddenSites, 0);
  const double rejectBelow = 0.5 * seed.volumes.minCoeff();
  std::map<int, int> outcomes;  // parts (1, 2, 4), or −1 for rejected
  for (int field = 2; field < 6; ++field)
    for (double scale : {1.5e-3, 2e-3, 3e-3}) {
      Eigen::VectorXd psi = psi0;
      for (int i = 0; i < n; ++i)
        psi[i] += scale * std::sin(6.0 * (field + 1) * y(i, 0) + 3.0 * field * y(i, 1)) *
                  std::cos(5.0 * (field + 2) * y(i, 2));
      const PowerDiagram fresh = computePowerDiagram(y, psi, Domain::unitCube(), CellMeasure::DualWhereInside, true);
      const PowerDiagram seeded = computePowerDiagram(y, psi, Domain::unitCube(), CellMeasure::DualWhereInside, true,
                                                      nullptr, &seed, rejectBelow);
      if (seeded.rejected) {
        EXPECT_LT(fresh.volumes.minCoeff(), rejectBelow) << field << " " << scale;
        EXPECT_FALSE(seeded.repaired);
        ++outcomes[-1];
        continue;
      }
      expectSameDiagram(seeded, fresh);
      if (seeded.repaired) {
        EXPECT_EQ(nonRegularFacets(seeded, y, psi), 0) << field << " " << scale;
        ++outcomes[seeded.repairParts];
      }
    }
  EXPECT_GE(outcomes[1], 1);
  EXPECT_GE(outcomes[2] + outcomes[4], 1);
  EXPECT_GE(outcomes[-1], 1);
}

TEST(PowerDiagram, RepairOnTheBallDomainWithTails) {
  const int n = 3000;
  const Eigen::MatrixX3d y = randomPointsInBall(n, 26, 0.9);
  const Eigen::VectorXd psi0 = randomWeights(n, 27, 3e-5);
  const Eigen::VectorXd psi = psi0 + randomWeights(n, 28, 3e-5);
  const Eigen::VectorXd tails = randomWeights(n, 29, 1e-19);
  const Domain ball = Domain::unitBall(4);
  const PowerDiagram seed = computePowerDiagram(y, psi0, ball);
  ASSERT_EQ(seed.hiddenSites, 0);
  const PowerDiagram fresh = computePowerDiagram(y, psi, ball, CellMeasure::DualWhereInside, false, &tails);
  const PowerDiagram repaired = computePowerDiagram(y, psi, ball, CellMeasure::DualWhereInside, false, &tails, &seed);
  EXPECT_TRUE(repaired.repaired);
  EXPECT_GT(repaired.flips, 0);
  expectSameDiagram(repaired, fresh);
  expectTiling(repaired, ball, 1e-12);
}

TEST(PowerDiagram, HiddenSitesAndTheirSeedsFallBackToInsertion) {
  Eigen::MatrixX3d y = randomPoints(300, 30);
  y.row(7) = 0.5 * (y.row(3) + y.row(4));
  Eigen::VectorXd psi = Eigen::VectorXd::Zero(300);
  const PowerDiagram visible = computePowerDiagram(y, psi, Domain::unitCube());
  ASSERT_EQ(visible.hiddenSites, 0);
  // The new weights hide site 7: no flip removes a vertex.
  psi[7] = -10;
  const PowerDiagram hidden = computePowerDiagram(y, psi, Domain::unitCube());
  const PowerDiagram fromVisible =
      computePowerDiagram(y, psi, Domain::unitCube(), CellMeasure::DualWhereInside, false, nullptr, &visible);
  EXPECT_FALSE(fromVisible.repaired);
  EXPECT_GE(fromVisible.hiddenSites, 1);
  expectSameDiagram(fromVisible, hidden);
  // A seed that hides a site cannot give it back.
  psi[7] = 0;
  const PowerDiagram fromHidden =
      computePowerDiagram(y, psi, Domain::unitCube(), CellMeasure::DualWhereInside, false, nullptr, &hidden);
  EXPECT_FALSE(fromHidden.repaired);
  expectSameDiagram(fromHidden, visible);
}

TEST(PowerDiagram, SitesOnTheHullsFacesAreNotRepaired) {
  // A 4×4×4 grid: sites inside the hull's square faces, whose own
  // triangulation flips of interior facets cannot make regular.
  Eigen::MatrixX3d y(64, 3);
  for (int i = 0; i < 64; ++i) y.row(i) << 0.125 + 0.25 * (i % 4), 0.125 + 0.25 * (i / 4 % 4), 0.125 + 0.25 * (i / 16);
  const Eigen::VectorXd psi0 = randomWeights(64, 31, 1e-3);
  const Eigen::VectorXd psi = randomWeights(64, 32, 1e-3);
  const PowerDiagram seed = computePowerDiagram(y, psi0, Domain::unitCube());
  const PowerDiagram fresh = computePowerDiagram(y, psi, Domain::unitCube());
  const PowerDiagram repaired =
      computePowerDiagram(y, psi, Domain::unitCube(), CellMeasure::DualWhereInside, false, nullptr, &seed);
  EXPECT_FALSE(repaired.repaired);
  expectSameDiagram(repaired, fresh);
  expectTiling(repaired, Domain::unitCube(), 1e-12);
}

TEST(PowerDiagram, SeedOfOtherSitesIsRefused) {
  const Eigen::MatrixX3d y = randomPoints(50, 33);
  const PowerDiagram seed = computePowerDiagram(y.topRows(40), Eigen::VectorXd::Zero(40), Domain::unitCube());
  try {
    computePowerDiagram(y, Eigen::VectorXd::Zero(50), Domain::unitCube(), CellMeasure::DualWhereInside, false,
                        nullptr, &seed);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::Usage);
    EXPECT_NE(std::string(e.what()).find("seed"), std::string::npos);
  }
  PowerDiagram broken = computePowerDiagram(y, Eigen::VectorXd::Zero(50), Domain::unitCube());
  ASSERT_FALSE(broken.tetVertex.empty());
  broken.tetVertex[0][2] = 50;
  EXPECT_THROW(computePowerDiagram(y, Eigen::VectorXd::Zero(50), Domain::unitCube(), CellMeasure::DualWhereInside,
                                   false, nullptr, &broken),
               Error);
  // Another point set of the same size: its tets are not all positive in
  // these sites, so the seed is given up and the diagram built afresh.
  const Eigen::MatrixX3d other = randomPoints(50, 34);
  const PowerDiagram foreign = computePowerDiagram(other, Eigen::VectorXd::Zero(50), Domain::unitCube());
  const PowerDiagram fresh = computePowerDiagram(y, Eigen::VectorXd::Zero(50), Domain::unitCube());
  const PowerDiagram fromForeign = computePowerDiagram(y, Eigen::VectorXd::Zero(50), Domain::unitCube(),
                                                       CellMeasure::DualWhereInside, false, nullptr, &foreign);
  EXPECT_FALSE(fromForeign.repaired);
  expectSameDiagram(fromForeign, fresh);
}
