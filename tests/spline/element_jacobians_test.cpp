// White-box test: the sum-factorised element Jacobians
// (spline/src/element_jacobians.h, internal) against the volume's own
// point evaluation, and the specialised loops against the general one bit
// for bit.
#include <gtest/gtest.h>

#include "../../spline/src/element_jacobians.h"

#include <tet2spline/spline/bspline_basis.h>
#include <tet2spline/spline/bspline_volume.h>

#include <array>
#include <random>
#include <vector>

using namespace tet2spline::spline;

namespace {

// Knots of degree p with `elements` spans of random lengths on [0, 1].
KnotVector randomKnots(int p, int elements, std::mt19937& rng) {
  std::uniform_real_distribution<double> len(0.3, 1.7);
  std::vector<double> bp{0.0};
  for (int e = 0; e < elements; ++e) bp.push_back(bp.back() + len(rng));
  for (double& b : bp) b /= bp.back();
  return KnotVector::fromBreakpoints(p, bp);
}

// One direction's table on element e: values and first derivatives at its
// p + 1 Gauss points, laid out as ElementBasis1D reads them.
struct Table {
  std::vector<double> ders, points;
};
Table elementTable(const KnotVector& K, int e) {
  const int p = K.degree(), s = K.elementSpans()[static_cast<size_t>(e)];
  const GaussRule r = gaussLegendre(p + 1, K[s], K[s + 1]);
  Table t;
  t.ders.resize(static_cast<size_t>((p + 1) * 2 * (p + 1)));
  for (int g = 0; g <= p; ++g) {
    basisDerivatives(K, s, r.points[g], 1, &t.ders[static_cast<size_t>(g * 2 * (p + 1))]);
    t.points.push_back(r.points[g]);
  }
  return t;
}

// Checks every element of a random volume with these degrees; returns the
// number of Gauss points compared.
int checkVolume(const std::array<int, 3>& deg, const std::array<int, 3>& elements, unsigned seed) {
  std::mt19937 rng(seed);
  std::array<KnotVector, 3> K;
  for (int d = 0; d < 3; ++d) K[d] = randomKnots(deg[d], elements[d], rng);
  const int nu = K[0].numBasis(), nv = K[1].numBasis(), nw = K[2].numBasis();
  // A perturbed grid, so that J is far from diagonal.
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);
  Eigen::MatrixX3d P(nu * nv * nw, 3);
  for (int k = 0; k < nw; ++k)
    for (int j = 0; j < nv; ++j)
      for (int i = 0; i < nu; ++i)
        P.row(i + nu * (j + nv * k)) << i + jitter(rng), j + jitter(rng) + 0.2 * i, k + jitter(rng) - 0.1 * j;
  const BSplineVolume V(K[0], K[1], K[2], P);
  int compared = 0;
  for (int ec = 0; ec < elements[2]; ++ec)
    for (int eb = 0; eb < elements[1]; ++eb)
      for (int ea = 0; ea < elements[0]; ++ea) {
        const std::array<int, 3> ei{ea, eb, ec};
        std::array<Table, 3> tables;
        std::array<detail::ElementBasis1D, 3> B;
        std::array<int, 3> first{};
        for (int d = 0; d < 3; ++d) {
          tables[d] = elementTable(K[d], ei[d]);
          B[d] = {deg[d] + 1, deg[d] + 1, 2, tables[d].ders.data()};
          first[d] = K[d].elementSpans()[static_cast<size_t>(ei[d])] - deg[d];
        }
        const int pa = deg[0] + 1, pb = deg[1] + 1, pc = deg[2] + 1;
        Eigen::MatrixX3d Pe(pa * pb * pc, 3);
        for (int c = 0; c < pc; ++c)
          for (int b = 0; b < pb; ++b)
            for (int a = 0; a < pa; ++a)
              Pe.row(a + pa * (b + pb * c)) = P.row((first[0] + a) + nu * ((first[1] + b) + nv * (first[2] + c)));
        std::vector<Eigen::Matrix3d> J, reference;
        detail::elementJacobians(B, Pe, J);
        detail::elementJacobiansGeneral(B, Pe, reference);
        EXPECT_EQ(J.size(), static_cast<size_t>(pa * pb * pc));
        EXPECT_EQ(J.size(), reference.size());
        for (int gc = 0; gc < pc; ++gc)
          for (int gb = 0; gb < pb; ++gb)
            for (int ga = 0; ga < pa; ++ga) {
              const size_t g = static_cast<size_t>(ga + pa * (gb + pb * gc));
              // The same sums in the same order: the same bits.
              for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c) EXPECT_EQ(J[g](r, c), reference[g](r, c)) << "point " << g;
              const Eigen::Vector3d u(tables[0].points[ga], tables[1].points[gb], tables[2].points[gc]);
              const Eigen::Matrix3d exact = V.jacobian(u);
              EXPECT_LT((J[g] - exact).norm(), 1e-11 * (1 + exact.norm())) << "point " << g << " at " << u.transpose();
              ++compared;
            }
      }
  return compared;
}

}  // namespace

TEST(ElementJacobians, EqualDegreesMatchThePointEvaluationAndTheGeneralLoop) {
  for (int p = 1; p <= 4; ++p)
    EXPECT_EQ(checkVolume({p, p, p}, {3, 2, 2}, 17u + static_cast<unsigned>(p)), 12 * (p + 1) * (p + 1) * (p + 1));
}

TEST(ElementJacobians, MixedAndHighDegreesTakeTheGeneralLoop) {
  EXPECT_EQ(checkVolume({2, 3, 1}, {2, 2, 3}, 5u), 12 * 3 * 4 * 2);
  EXPECT_EQ(checkVolume({5, 5, 5}, {2, 1, 1}, 9u), 2 * 6 * 6 * 6);
}
