#include <tet2spline/spline/knot_vector.h>

#include <tet2spline/param/error.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace tet2spline::spline {
namespace {
[[noreturn]] void fail(const std::string& what) {
  throw Error(ErrorKind::Usage, "KnotVector: " + what);
}
}  // namespace

KnotVector::KnotVector(int degree, std::vector<double> knots) : p_(degree), U_(std::move(knots)) {
  if (p_ < 0) fail("negative degree " + std::to_string(p_));
  const int m = size();
  if (m < 2 * (p_ + 1)) {
    fail(std::to_string(m) + " knots, a clamped knot vector of degree " + std::to_string(p_) +
         " needs at least " + std::to_string(2 * (p_ + 1)));
  }
  for (int i = 0; i < m; ++i) {
    if (!std::isfinite(U_[i])) fail("knot " + std::to_string(i) + " is not finite");
    if (i > 0 && U_[i] < U_[i - 1]) fail("knots decrease at index " + std::to_string(i));
  }
  for (int i = 1; i <= p_; ++i) {
    if (U_[i] != U_[0] || U_[m - 1 - i] != U_[m - 1]) {
      fail("not clamped: the first and last " + std::to_string(p_ + 1) + " knots must be equal");
    }
  }
  if (!(front() < back())) fail("empty domain");
  for (int i = p_ + 1; i < m - p_ - 1;) {
    int j = i;
    while (j < m - p_ - 1 && U_[j] == U_[i]) ++j;
    if (U_[i] != front() && U_[i] != back() && j - i > std::max(p_, 1)) {
      std::ostringstream os;
      os << "interior knot " << U_[i] << " has multiplicity " << j - i << " > max(degree, 1) = " << std::max(p_, 1);
      fail(os.str());
    }
    if (U_[i] == front() || U_[i] == back()) fail("end knot repeated more than p + 1 times");
    i = j;
  }
}

KnotVector KnotVector::uniform(int degree, int numElements, double a, double b) {
  if (numElements < 1) fail("uniform: " + std::to_string(numElements) + " elements");
  if (!(a < b)) fail("uniform: empty interval");
  std::vector<double> bp(static_cast<size_t>(numElements) + 1);
  for (int i = 0; i <= numElements; ++i) bp[i] = a + (b - a) * i / numElements;
  bp.back() = b;
  return fromBreakpoints(degree, bp);
}

KnotVector KnotVector::fromBreakpoints(int degree, const std::vector<double>& breakpoints) {
  if (degree < 0) fail("negative degree " + std::to_string(degree));
  if (breakpoints.size() < 2) fail("fromBreakpoints: fewer than 2 breakpoints");
  for (size_t i = 1; i < breakpoints.size(); ++i) {
    if (!(breakpoints[i] > breakpoints[i - 1])) fail("fromBreakpoints: breakpoints not strictly increasing");
  }
  std::vector<double> U;
  U.insert(U.end(), static_cast<size_t>(degree), breakpoints.front());
  U.insert(U.end(), breakpoints.begin(), breakpoints.end());
  U.insert(U.end(), static_cast<size_t>(degree), breakpoints.back());
  return KnotVector(degree, std::move(U));
}

int KnotVector::findSpan(double u) const {
  const int n = numBasis() - 1;  // Piegl & Tiller's n: index of the last basis function
  if (u >= U_[n + 1]) {
    // Last non-empty span.
    int s = n;
    while (s > p_ && U_[s] == U_[s + 1]) --s;
    return s;
  }
  if (u <= U_[p_]) {
    int s = p_;
    while (s < n && U_[s] == U_[s + 1]) ++s;
    return s;
  }
  // U[s] <= u < U[s+1]: upper_bound gives the first knot > u.
  const auto it = std::upper_bound(U_.begin() + p_, U_.begin() + n + 2, u);
  return static_cast<int>(it - U_.begin()) - 1;
}

std::vector<double> KnotVector::breakpoints() const {
  std::vector<double> b;
  for (int i = p_; i <= numBasis(); ++i) {
    if (b.empty() || U_[i] != b.back()) b.push_back(U_[i]);
  }
  return b;
}

std::vector<int> KnotVector::elementSpans() const {
  std::vector<int> s;
  for (int i = p_; i < numBasis(); ++i) {
    if (U_[i] < U_[i + 1]) s.push_back(i);
  }
  return s;
}

int KnotVector::multiplicity(double u) const {
  return static_cast<int>(std::count(U_.begin(), U_.end(), u));
}

Eigen::VectorXd KnotVector::greville() const {
  const int n = numBasis();
  Eigen::VectorXd g(n);
  for (int i = 0; i < n; ++i) {
    if (p_ == 0) {
      g[i] = 0.5 * (U_[i] + U_[i + 1]);
      continue;
    }
    double s = 0;
    for (int j = 1; j <= p_; ++j) s += U_[i + j];
    g[i] = s / p_;
  }
  return g;
}

}  // namespace tet2spline::spline
