// Winding numbers of closed triangle shells (see shell_geometry.h).
#include "shell_geometry.h"

#include <Eigen/Geometry>
#include <cmath>
#include <limits>

namespace tet2spline {

namespace {
constexpr double kPi = 3.14159265358979323846;
}

ShellGeometry::ShellGeometry(const SurfaceMesh& surface, const SurfaceReport& report)
    : V_(surface.V), F_(surface.F), report_(report) {
  const auto n = report.shells.size();
  lo_.resize(n), hi_.resize(n);
  for (std::size_t s = 0; s < n; ++s) {
    lo_[s].setConstant(std::numeric_limits<double>::infinity());
    hi_[s].setConstant(-std::numeric_limits<double>::infinity());
    for (int f : report.shellFaces[s])
      for (int k = 0; k < 3; ++k) {
        lo_[s] = lo_[s].cwiseMin(V_.row(F_(f, k)).transpose());
        hi_[s] = hi_[s].cwiseMax(V_.row(F_(f, k)).transpose());
      }
  }
}

double ShellGeometry::volume(int s) const { return std::abs(report_.shells[s].enclosedVolume); }

double ShellGeometry::winding(int s, const Eigen::Vector3d& p) const {
  if ((p.array() < lo_[s].array()).any() || (p.array() > hi_[s].array()).any()) return 0;
  double sum = 0;
  for (int f : report_.shellFaces[s]) {
    const Eigen::Vector3d a = V_.row(F_(f, 0)).transpose() - p, b = V_.row(F_(f, 1)).transpose() - p,
                          c = V_.row(F_(f, 2)).transpose() - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double num = a.dot(b.cross(c));
    const double den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    sum += 2 * std::atan2(num, den);
  }
  return sign(s) * sum / (4 * kPi);
}

int ShellGeometry::inside(int s, const Eigen::Vector3d& p) const {
  const double w = winding(s, p);
  const double r = std::round(w);
  if (std::abs(w - r) > 0.2) return -1;
  return r != 0 ? 1 : 0;
}

bool ShellGeometry::nesting(std::vector<int>& parent, std::vector<int>& depth, int& tooCloseA,
                            int& tooCloseB) const {
  const int n = size();
  parent.assign(n, -1);
  depth.assign(n, 0);
  // Shells do not intersect, so shell i is inside shell j when any vertex of i
  // is; a vertex very close to j leaves the winding number undecided, so try a few.
  for (int i = 0; i < n; ++i) {
    const auto& faces = report_.shellFaces[i];
    for (int j = 0; j < n; ++j) {
      if (j == i) continue;
      int in = -1;
      for (std::size_t k = 0; k < faces.size() && k < 8 && in < 0; ++k)
        in = inside(j, vertex(F_(faces[k * faces.size() / 8], 0)));
      if (in < 0) {
        tooCloseA = i, tooCloseB = j;
        return false;
      }
      if (in == 1) {
        ++depth[i];
        if (parent[i] < 0 || volume(j) < volume(parent[i])) parent[i] = j;
      }
    }
  }
  return true;
}

}  // namespace tet2spline
