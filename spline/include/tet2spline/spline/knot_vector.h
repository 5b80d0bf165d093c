#pragma once
/// Clamped (open) knot vectors of B-splines (Piegl & Tiller, "The NURBS Book",
/// 2nd ed., ch. 2). A knot vector of degree p with n basis functions holds
/// n + p + 1 non-decreasing knots whose first p + 1 and last p + 1 are equal
/// (the curve interpolates its end coefficients). Letters follow the book:
/// p degree, U knots, n number of basis functions (control points).

#include <Eigen/Core>
#include <vector>

namespace tet2spline::spline {

class KnotVector {
 public:
  KnotVector() = default;
  /// Takes the full knot sequence. Throws Error(Usage) unless degree >= 0,
  /// the knots are finite and non-decreasing, clamped at both ends (p + 1 equal
  /// end knots), every interior knot has multiplicity <= max(p, 1), and the domain is
  /// not empty.
  KnotVector(int degree, std::vector<double> knots);

  /// Degree p, `numElements` equal spans on [a, b], clamped.
  static KnotVector uniform(int degree, int numElements, double a = 0.0, double b = 1.0);
  /// Degree p, clamped, with simple interior knots at the given strictly
  /// increasing breakpoints (first and last are the ends of the domain).
  static KnotVector fromBreakpoints(int degree, const std::vector<double>& breakpoints);

  int degree() const { return p_; }
  const std::vector<double>& knots() const { return U_; }
  double operator[](int i) const { return U_[static_cast<size_t>(i)]; }
  int size() const { return static_cast<int>(U_.size()); }
  /// Number of basis functions (control points): #knots − p − 1.
  int numBasis() const { return size() - p_ - 1; }
  double front() const { return U_[static_cast<size_t>(p_)]; }
  double back() const { return U_[static_cast<size_t>(numBasis())]; }

  /// Index s with U[s] <= u < U[s+1], p <= s <= n−1 (Piegl & Tiller A2.1);
  /// u is clamped to [front, back] and u == back gives the last non-empty span.
  int findSpan(double u) const;
  /// Distinct knot values, front to back (the element boundaries).
  std::vector<double> breakpoints() const;
  /// Number of non-empty knot spans (Bézier elements).
  int numElements() const { return static_cast<int>(breakpoints().size()) - 1; }
  /// Indices s of the non-empty spans [U[s], U[s+1]), in increasing order.
  std::vector<int> elementSpans() const;
  /// Multiplicity of the knot value u (0 if u is not a knot; exact comparison).
  int multiplicity(double u) const;
  /// Greville abscissae (mean of p consecutive interior knots), #n; the
  /// coefficients that reproduce the identity map u -> u (linear precision).
  Eigen::VectorXd greville() const;

  bool operator==(const KnotVector& o) const { return p_ == o.p_ && U_ == o.U_; }
  bool operator!=(const KnotVector& o) const { return !(*this == o); }

 private:
  int p_ = 0;
  std::vector<double> U_;
};

}  // namespace tet2spline::spline
