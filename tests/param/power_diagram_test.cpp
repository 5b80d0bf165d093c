// Laws of clipped power diagrams: the cells tile Ω, facets are shared, simple
// configurations have known cells, hidden and coincident sites do not crash.
#include "tet2spline/param/power_diagram.h"

#include <gtest/gtest.h>

#include <cmath>
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
