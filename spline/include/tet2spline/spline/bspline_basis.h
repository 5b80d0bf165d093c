#pragma once
/// B-spline basis functions, their derivatives, Gauss–Legendre rules per knot
/// span, and the two exact refinements of a spline's coefficients: knot
/// insertion (Boehm; Piegl & Tiller A5.1) and degree elevation.
/// Letters follow Piegl & Tiller: p degree, s span index, N basis values.
///
/// Coefficient sets are #n × dim matrices (one row per basis function), so a
/// curve, one coordinate of a surface, or one line of a volume's control grid
/// are handled alike. Refinements are also returned as matrices M with
/// new = M · old, which is how BSplineVolume refines one direction at a time.

#include <Eigen/Core>
#include <tet2spline/spline/knot_vector.h>
#include <vector>

namespace tet2spline::spline {

/// Largest degree the basis routines accept (fixed-size work arrays).
inline constexpr int kMaxDegree = 15;

/// The p + 1 basis functions that are non-zero on span s at u: N[0..p] =
/// N_{s−p,p}(u) … N_{s,p}(u) (Piegl & Tiller A2.2). N must hold p + 1 values.
void basisFunctions(const KnotVector& U, int s, double u, double* N);

/// Basis functions and their derivatives up to order k on span s (Piegl &
/// Tiller A2.3): ders[d*(p+1) + j] = d^d/du^d N_{s−p+j,p}(u), d = 0..k.
/// Derivatives beyond p are zero. ders must hold (k + 1)(p + 1) values.
void basisDerivatives(const KnotVector& U, int s, double u, int k, double* ders);

/// Convenience form: (k + 1) × (p + 1) matrix, row d holds the d-th derivatives.
Eigen::MatrixXd basisDerivatives(const KnotVector& U, int s, double u, int k);

/// Dense #points × n matrix of basis values (row r: N_j(u_r) for all j).
Eigen::MatrixXd basisMatrix(const KnotVector& U, const Eigen::VectorXd& u, int derivative = 0);

/// Gauss–Legendre quadrature: points and weights.
struct GaussRule {
  Eigen::VectorXd points;
  Eigen::VectorXd weights;
};
/// n-point rule on [a, b] (exact for polynomials of degree <= 2n − 1).
GaussRule gaussLegendre(int n, double a = -1.0, double b = 1.0);
/// The n-point rule on every non-empty span of U, concatenated front to back.
GaussRule gaussPointsPerSpan(const KnotVector& U, int n);

/// A spline function's knots and coefficients (#n × dim).
struct SplineCoefficients {
  KnotVector knots;
  Eigen::MatrixXd coefficients;
};
/// Knots after inserting u `times` times, and M (#n_new × #n_old) with
/// new coefficients = M · old; the spline is unchanged (Boehm). Throws
/// Error(Usage) if u is outside the domain's interior or the multiplicity
/// would exceed p.
std::pair<KnotVector, Eigen::MatrixXd> knotInsertionMatrix(const KnotVector& U, double u, int times = 1);
/// Knots of degree p + t (every distinct knot's multiplicity grows by t), and
/// M with new coefficients = M · old; the spline is unchanged. M is found by
/// interpolating the old basis at the Greville abscissae of the new one, which
/// is exact because the old spline space is contained in the new one.
/// Degree 0 (discontinuous) splines throw Error(Usage).
std::pair<KnotVector, Eigen::MatrixXd> degreeElevationMatrix(const KnotVector& U, int t = 1);

SplineCoefficients insertKnot(const SplineCoefficients& c, double u, int times = 1);
SplineCoefficients elevateDegree(const SplineCoefficients& c, int t = 1);

/// Value (and derivative order k) of a spline curve at u: Σ_j N_j^{(k)}(u) c_j.
Eigen::RowVectorXd evaluateCurve(const SplineCoefficients& c, double u, int k = 0);

}  // namespace tet2spline::spline
