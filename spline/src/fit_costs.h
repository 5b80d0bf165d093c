#pragma once
// Ceres cost functions of the B-spline fit (internal: Ceres types stay out of
// the public headers). Every cost acts on the (p+1)(q+1)(r+1) control points
// of one Bézier element, one parameter block of size 3 per control point, in
// the element's local order (u fastest). Derivatives are analytic.

#include <ceres/cost_function.h>

#include <Eigen/Core>
#include <algorithm>

namespace tet2spline::spline::detail {

/// Data residual of one point: sqrt(w) (Σ_l N_l P_l − X), 3 residuals.
class PointDataCost final : public ceres::CostFunction {
 public:
  /// N: tensor basis values of the point's element (#local), X the target.
  PointDataCost(Eigen::VectorXd N, const Eigen::Vector3d& X, double sqrtWeight)
      : N_(std::move(N)), X_(X), s_(sqrtWeight) {
    set_num_residuals(3);
    mutable_parameter_block_sizes()->assign(static_cast<size_t>(N_.size()), 3);
  }
  bool Evaluate(double const* const* P, double* r, double** J) const override {
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    for (Eigen::Index l = 0; l < N_.size(); ++l) x += N_[l] * Eigen::Map<const Eigen::Vector3d>(P[l]);
    Eigen::Map<Eigen::Vector3d> res(r);
    res = s_ * (x - X_);
    if (J) {
      for (Eigen::Index l = 0; l < N_.size(); ++l) {
        if (!J[l]) continue;
        Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> Jl(J[l]);
        Jl = (s_ * N_[l]) * Eigen::Matrix3d::Identity();
      }
    }
    return true;
  }

 private:
  Eigen::VectorXd N_;
  Eigen::Vector3d X_;
  double s_;
};

/// A quadratic form of one element written as least squares: residuals
/// r[c*m + a] = Σ_l R(a,l) P_l[c] − D(a,c), c = x,y,z, so that
/// |r|² = Σ_c (P_c^T RᵀR P_c − 2 DᵀR P_c) + const (used for the smoothing term,
/// with RᵀR the element's thin-plate matrix and D = 0).
class ElementQuadraticCost final : public ceres::CostFunction {
 public:
  ElementQuadraticCost(Eigen::MatrixXd R, Eigen::MatrixX3d D) : R_(std::move(R)), D_(std::move(D)) {
    set_num_residuals(static_cast<int>(3 * R_.rows()));
    mutable_parameter_block_sizes()->assign(static_cast<size_t>(R_.cols()), 3);
  }
  bool Evaluate(double const* const* P, double* r, double** J) const override {
    const Eigen::Index m = R_.rows(), n = R_.cols();
    Eigen::MatrixX3d Pl(n, 3);
    for (Eigen::Index l = 0; l < n; ++l) Pl.row(l) = Eigen::Map<const Eigen::RowVector3d>(P[l]);
    const Eigen::MatrixX3d res = R_ * Pl - D_;  // m × 3
    for (int c = 0; c < 3; ++c) Eigen::Map<Eigen::VectorXd>(r + c * m, m) = res.col(c);
    if (J) {
      for (Eigen::Index l = 0; l < n; ++l) {
        if (!J[l]) continue;
        Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>> Jl(J[l], 3 * m, 3);
        Jl.setZero();
        for (int c = 0; c < 3; ++c) Jl.block(c * m, c, m, 1) = R_.col(l);
      }
    }
    return true;
  }

 private:
  Eigen::MatrixXd R_;
  Eigen::MatrixX3d D_;
};

/// Validity penalty at one Gauss point: s · max(0, τ − det J), one residual.
/// G (3 × #local) holds ∂/∂u, ∂/∂v, ∂/∂w of the tensor basis at the point,
/// so J = [x_u x_v x_w] with x_d = Σ_l G(d,l) P_l and
/// ∂ det J / ∂P_l = G(0,l) x_v×x_w + G(1,l) x_w×x_u + G(2,l) x_u×x_v.
class DetJPenaltyCost final : public ceres::CostFunction {
 public:
  DetJPenaltyCost(Eigen::Matrix3Xd G, double threshold, double scale)
      : G_(std::move(G)), tau_(threshold), s_(scale) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->assign(static_cast<size_t>(G_.cols()), 3);
  }
  static double detJ(const Eigen::Matrix3Xd& G, double const* const* P, Eigen::Matrix3d* Jout = nullptr) {
    Eigen::Matrix3d Jm = Eigen::Matrix3d::Zero();
    for (Eigen::Index l = 0; l < G.cols(); ++l) Jm += Eigen::Map<const Eigen::Vector3d>(P[l]) * G.col(l).transpose();
    if (Jout) *Jout = Jm;
    return Jm.determinant();
  }
  bool Evaluate(double const* const* P, double* r, double** J) const override {
    Eigen::Matrix3d Jm;
    const double d = detJ(G_, P, &Jm);
    const bool active = d < tau_;
    r[0] = active ? s_ * (tau_ - d) : 0.0;
    if (J) {
      const Eigen::Vector3d cu = Jm.col(1).cross(Jm.col(2)), cv = Jm.col(2).cross(Jm.col(0)),
                            cw = Jm.col(0).cross(Jm.col(1));
      for (Eigen::Index l = 0; l < G_.cols(); ++l) {
        if (!J[l]) continue;
        Eigen::Map<Eigen::RowVector3d> Jl(J[l]);
        if (active) {
          Jl = -s_ * (G_(0, l) * cu + G_(1, l) * cv + G_(2, l) * cw).transpose();
        } else {
          Jl.setZero();
        }
      }
    }
    return true;
  }

 private:
  Eigen::Matrix3Xd G_;
  double tau_, s_;
};

}  // namespace tet2spline::spline::detail
