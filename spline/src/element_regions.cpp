#include <tet2spline/spline/element_regions.h>

#include <tet2spline/param/error.h>

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <string>

namespace tet2spline::spline {
namespace {

[[noreturn]] void usage(const std::string& who, const std::string& what) {
  throw Error(ErrorKind::Usage, who + ": " + what);
}

void checkMesh(const char* who, Eigen::Index numVertices, const Eigen::MatrixX4i& T) {
  if (T.rows() == 0) usage(who, "no tets");
  if (T.minCoeff() < 0 || T.maxCoeff() >= numVertices)
    usage(who, "tet vertex index outside 0.." + std::to_string(numVertices - 1));
}

// Tet t's edges from its first corner, as columns.
Eigen::Matrix3d edgeMatrix(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T, Eigen::Index t) {
  const Eigen::RowVector3d a = X.row(T(t, 0));
  Eigen::Matrix3d E;
  for (int c = 0; c < 3; ++c) E.col(c) = (X.row(T(t, c + 1)) - a).transpose();
  return E;
}

double tetVolume(const Eigen::MatrixX3d& X, const Eigen::MatrixX4i& T, Eigen::Index t) {
  return edgeMatrix(X, T, t).determinant() / 6.0;
}

// The parameters' checks (indices, finite values) and the bar a tet's
// |det E| must pass to be usable: 1e-14 of the parameter box's diagonal
// cubed (slivers below it have no reliable inverse).
double checkedUsableBar(const char* who, const Eigen::MatrixX3d& U, const Eigen::MatrixX4i& T) {
  checkMesh(who, U.rows(), T);
  if (!U.allFinite()) usage(who, "non-finite parameters");
  const double diag = (U.colwise().maxCoeff() - U.colwise().minCoeff()).cwiseMax(1e-300).norm();
  return 1e-14 * diag * diag * diag;
}

}  // namespace

ParameterLocator::ParameterLocator(const Eigen::MatrixX3d& U, const Eigen::MatrixX4i& T) : U_(U), T_(T) {
  const double usable = checkedUsableBar("ParameterLocator", U, T);
  const Eigen::Index nt = T.rows();
  inverse_.assign(static_cast<size_t>(nt), Eigen::Matrix3d::Zero());
  lo_ = U.colwise().minCoeff().transpose();
  hi_ = U.colwise().maxCoeff().transpose();
  const Eigen::Vector3d ext = (hi_ - lo_).cwiseMax(1e-300);
  // About two tets per bucket; at most 256 buckets per direction.
  const int m = std::clamp(static_cast<int>(std::cbrt(static_cast<double>(nt) / 2.0)), 1, 256);
  n_ = Eigen::Vector3i::Constant(m);
  std::vector<std::array<int, 6>> box(static_cast<size_t>(nt));
  first_.assign(static_cast<size_t>(n_.prod()) + 1, 0);
  auto cell = [&](double x, int d) {
    return std::clamp(static_cast<int>((x - lo_[d]) / ext[d] * n_[d]), 0, n_[d] - 1);
  };
  for (Eigen::Index t = 0; t < nt; ++t) {
    const Eigen::RowVector3d a = U.row(T(t, 0));
    const Eigen::Matrix3d E = edgeMatrix(U, T, t);
    if (std::fabs(E.determinant()) > usable) inverse_[static_cast<size_t>(t)] = E.inverse();
    auto& b = box[static_cast<size_t>(t)];
    for (int d = 0; d < 3; ++d) {
      double mn = a[d], mx = a[d];
      for (int c = 1; c < 4; ++c) {
        mn = std::min(mn, U(T(t, c), d));
        mx = std::max(mx, U(T(t, c), d));
      }
      b[2 * d] = cell(mn, d);
      b[2 * d + 1] = cell(mx, d);
    }
    for (int k = b[4]; k <= b[5]; ++k)
      for (int j = b[2]; j <= b[3]; ++j)
        for (int i = b[0]; i <= b[1]; ++i) ++first_[static_cast<size_t>(bucketIndex(i, j, k)) + 1];
  }
  for (size_t i = 1; i < first_.size(); ++i) first_[i] += first_[i - 1];
  items_.resize(static_cast<size_t>(first_.back()));
  std::vector<long> fill(first_.begin(), first_.end() - 1);
  for (Eigen::Index t = 0; t < nt; ++t) {
    const auto& b = box[static_cast<size_t>(t)];
    for (int k = b[4]; k <= b[5]; ++k)
      for (int j = b[2]; j <= b[3]; ++j)
        for (int i = b[0]; i <= b[1]; ++i) items_[static_cast<size_t>(fill[static_cast<size_t>(bucketIndex(i, j, k))]++)] = t;
  }
}

Eigen::Vector4d ParameterLocator::barycentric(long t, const Eigen::Vector3d& u) const {
  const Eigen::Vector3d l = inverse_[static_cast<size_t>(t)] * (u - U_.row(T_(t, 0)).transpose());
  return {1.0 - l.sum(), l[0], l[1], l[2]};
}

long ParameterLocator::locate(const Eigen::Vector3d& u) const {
  const Eigen::Vector3d ext = (hi_ - lo_).cwiseMax(1e-300);
  Eigen::Vector3i c;
  for (int d = 0; d < 3; ++d) c[d] = std::clamp(static_cast<int>((u[d] - lo_[d]) / ext[d] * n_[d]), 0, n_[d] - 1);
  long best = -1;
  double bestScore = -std::numeric_limits<double>::infinity();
  // Ring r = the buckets at Chebyshev distance r from c. A point inside some
  // image is found in ring 0; otherwise widen until a ring has candidates,
  // then one more ring (a nearer tet may sit just across a bucket face).
  int lastRing = std::max({n_[0], n_[1], n_[2]});
  for (int r = 0; r <= lastRing; ++r) {
    bool any = false;
    for (int k = c[2] - r; k <= c[2] + r; ++k)
      for (int j = c[1] - r; j <= c[1] + r; ++j)
        for (int i = c[0] - r; i <= c[0] + r; ++i) {
          if (std::max({std::abs(i - c[0]), std::abs(j - c[1]), std::abs(k - c[2])}) != r) continue;
          if (i < 0 || j < 0 || k < 0 || i >= n_[0] || j >= n_[1] || k >= n_[2]) continue;
          const long b = bucketIndex(i, j, k);
          for (long at = first_[static_cast<size_t>(b)]; at < first_[static_cast<size_t>(b) + 1]; ++at) {
            const long t = items_[static_cast<size_t>(at)];
            if (inverse_[static_cast<size_t>(t)].isZero(0)) continue;
            any = true;
            const double score = barycentric(t, u).minCoeff();
            if (score > bestScore) {
              bestScore = score;
              best = t;
            }
          }
        }
    if (bestScore >= 0) return best;  // inside (ring 0 holds every image that contains u)
    if (any && lastRing > r + 1) lastRing = r + 1;
  }
  return best;
}

std::vector<int> elementRegions(const BSplineVolume& volume, const Eigen::MatrixX3d& U, const Eigen::MatrixX4i& T,
                                const Eigen::VectorXi& region) {
  if (region.size() != T.rows())
    usage("elementRegions", std::to_string(region.size()) + " region tags for " + std::to_string(T.rows()) + " tets");
  // One region (the common case): every element is in it, and the locator
  // (per-tet inverses and buckets: 0.6 s on bunny00's 767k tets, on one
  // core) would only confirm it. Its checks stay.
  if (region.size() > 0 && (region.array() == region[0]).all()) {
    const double usable = checkedUsableBar("elementRegions", U, T);
    for (Eigen::Index t = 0; t < T.rows(); ++t)
      if (std::fabs(edgeMatrix(U, T, t).determinant()) > usable)
        return std::vector<int>(static_cast<size_t>(volume.numElements().prod()), region[0]);
    usage("elementRegions", "every tet's parameter image is degenerate");
  }
  const ParameterLocator locator(U, T);
  const std::vector<BezierElement> elements = volume.elements();
  std::vector<int> out(elements.size(), 0);
  for (size_t e = 0; e < elements.size(); ++e) {
    const long t = locator.locate(elements[e].centre);
    if (t < 0) usage("elementRegions", "every tet's parameter image is degenerate");
    out[e] = region[t];
  }
  return out;
}

std::vector<RegionElementDensity> regionElementDensity(const std::vector<int>& elementRegion,
                                                       const Eigen::MatrixX3d& V, const Eigen::MatrixX3d& U,
                                                       const Eigen::MatrixX4i& T, const Eigen::VectorXi& region) {
  const char* who = "regionElementDensity";
  if (V.rows() != U.rows())
    usage(who, std::to_string(V.rows()) + " positions but " + std::to_string(U.rows()) + " parameters");
  checkMesh(who, V.rows(), T);
  if (region.size() != T.rows())
    usage(who, std::to_string(region.size()) + " region tags for " + std::to_string(T.rows()) + " tets");
  std::map<int, RegionElementDensity> byId;
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    RegionElementDensity& r = byId[region[t]];
    r.id = region[t];
    r.volume += std::fabs(tetVolume(V, T, t));
    r.parametricVolume += std::fabs(tetVolume(U, T, t));
  }
  for (int id : elementRegion) {
    auto it = byId.find(id);
    if (it == byId.end()) usage(who, "element region " + std::to_string(id) + " is not a region of the mesh");
    ++it->second.elements;
  }
  std::vector<RegionElementDensity> out;
  for (auto& [id, r] : byId) {
    r.elementsPerVolume = r.volume > 0 ? static_cast<double>(r.elements) / r.volume : 0.0;
    out.push_back(r);
  }
  return out;
}

}  // namespace tet2spline::spline
