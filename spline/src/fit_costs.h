#pragma once
// Ceres cost functions of the B-spline fit (internal: Ceres types stay out of
// the public headers). Every cost acts on the control points of one Bézier
// element (#local = (p+1)(q+1)(r+1), local order u fastest) and has analytic
// derivatives.
//
// The linear stage (PointDataCost, ElementQuadraticCost) uses scalar blocks,
// one per coordinate of each control point: its terms act on x, y and z
// separately, so 3-vector blocks would be two thirds structural zeros.
// The validity stage (DetJPenaltyCost, ElementQuadraticCost3) uses one
// 3-vector block per control point: det J couples the three coordinates, and
// Ceres' cost of forming JᵀJ grows with the number of block pairs (each
// penalty residual touches 3·#local scalar blocks = (3·#local)² pairs, which
// made InnerProductComputer dominate the profile: measured 55 s for 729
// control points with scalar blocks).

#include <ceres/cost_function.h>

#include <Eigen/Core>
#include <Eigen/LU>
#include <algorithm>

namespace tet2spline::spline::detail {

/// Data residual of one point in one coordinate: sqrt(w) (Σ_l N_l P_l − X).
/// Blocks: the #local scalars P_l of that coordinate.
class PointDataCost final : public ceres::CostFunction {
 public:
  /// N: tensor basis values of the point's element (#local), X the target coordinate.
  PointDataCost(Eigen::VectorXd N, double X, double sqrtWeight) : N_(std::move(N)), X_(X), s_(sqrtWeight) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->assign(static_cast<size_t>(N_.size()), 1);
  }
  bool Evaluate(double const* const* P, double* r, double** J) const override {
    double x = 0.0;
    for (Eigen::Index l = 0; l < N_.size(); ++l) x += N_[l] * P[l][0];
    r[0] = s_ * (x - X_);
    if (J) {
      for (Eigen::Index l = 0; l < N_.size(); ++l)
        if (J[l]) J[l][0] = s_ * N_[l];
    }
    return true;
  }

 private:
  Eigen::VectorXd N_;
  double X_;
  double s_;
};

/// A quadratic form of one element in one coordinate, written as least
/// squares: r = R p − d (R: m × #local), so |r|² = pᵀRᵀR p − 2 dᵀR p + |d|².
/// Used for the data and smoothing terms of an element together, with
/// RᵀR = H_e and Rᵀd = b_e (the element's normal equations).
class ElementQuadraticCost final : public ceres::CostFunction {
 public:
  ElementQuadraticCost(Eigen::MatrixXd R, Eigen::VectorXd d) : R_(std::move(R)), d_(std::move(d)) {
    set_num_residuals(static_cast<int>(R_.rows()));
    mutable_parameter_block_sizes()->assign(static_cast<size_t>(R_.cols()), 1);
  }
  bool Evaluate(double const* const* P, double* r, double** J) const override {
    const Eigen::Index m = R_.rows(), n = R_.cols();
    Eigen::VectorXd p(n);
    for (Eigen::Index l = 0; l < n; ++l) p[l] = P[l][0];
    Eigen::Map<Eigen::VectorXd> res(r, m);
    res = R_ * p - d_;
    if (J) {
      for (Eigen::Index l = 0; l < n; ++l) {
        if (!J[l]) continue;
        Eigen::Map<Eigen::VectorXd> Jl(J[l], m);
        Jl = R_.col(l);
      }
    }
    return true;
  }

 private:
  Eigen::MatrixXd R_;
  Eigen::VectorXd d_;
};

/// Validity penalty at one Gauss point: s · max(0, τ − det J), one residual.
/// Blocks: #local 3-vectors, block l = control point l.
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
    for (Eigen::Index l = 0; l < G.cols(); ++l) {
      const Eigen::Vector3d Pl(P[l][0], P[l][1], P[l][2]);
      Jm += Pl * G.col(l).transpose();
    }
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
        const Eigen::Vector3d g = active ? Eigen::Vector3d(-s_ * (G_(0, l) * cu + G_(1, l) * cv + G_(2, l) * cw))
                                         : Eigen::Vector3d::Zero();
        if (J[l])
          for (int c = 0; c < 3; ++c) J[l][c] = g[c];
      }
    }
    return true;
  }

 private:
  Eigen::Matrix3Xd G_;
  double tau_, s_;
};

/// ElementQuadraticCost for the three coordinates at once, on 3-vector blocks
/// (the validity stage's layout): r = [R p_x − d_x; R p_y − d_y; R p_z − d_z],
/// block l = control point l, so the Jacobian block of l is R(:,l) ⊗ I_3
/// arranged as 3m × 3 (row c·m + i, column c).
class ElementQuadraticCost3 final : public ceres::CostFunction {
 public:
  ElementQuadraticCost3(Eigen::MatrixXd R, Eigen::MatrixX3d D) : R_(std::move(R)), D_(std::move(D)) {
    set_num_residuals(static_cast<int>(3 * R_.rows()));
    mutable_parameter_block_sizes()->assign(static_cast<size_t>(R_.cols()), 3);
  }
  bool Evaluate(double const* const* P, double* r, double** J) const override {
    const Eigen::Index m = R_.rows(), n = R_.cols();
    Eigen::MatrixX3d p(n, 3);
    for (Eigen::Index l = 0; l < n; ++l) p.row(l) << P[l][0], P[l][1], P[l][2];
    Eigen::Map<Eigen::MatrixX3d> res(r, m, 3);  // column c = residuals of coordinate c
    res = R_ * p - D_;
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

}  // namespace tet2spline::spline::detail
