#pragma once
/// Trivariate tensor-product B-spline volumes and their boundary surfaces
/// (design.md, "Trivariate B-spline and fitting").
///
/// x(u,v,w) = Σ_ijk N_i(u) N_j(v) N_k(w) P_ijk on the parameter box
/// [u0,u1]×[v0,v1]×[w0,w1] (usually [0,1]^3), clamped knot vectors of degree
/// (p, q, r). Control points are a #ctrl × 3 matrix with u fastest, then v,
/// then w: row i + n_u*(j + n_v*k). The Jacobian J = [x_u x_v x_w] has the
/// partial derivatives as columns.

#include <Eigen/Core>
#include <array>
#include <tet2spline/spline/bspline_basis.h>
#include <tet2spline/spline/knot_vector.h>
#include <vector>

namespace tet2spline::spline {

/// Tensor-product B-spline surface S(s,t) = Σ_ij N_i(s) N_j(t) P_ij; control
/// points #n_s*n_t × 3, s fastest (row i + n_s*j).
class BSplineSurface {
 public:
  BSplineSurface() = default;
  /// Throws Error(Usage) unless P has knots[0].numBasis()*knots[1].numBasis() rows.
  BSplineSurface(KnotVector s, KnotVector t, Eigen::MatrixX3d controlPoints);

  const KnotVector& knots(int dir) const { return knots_[dir]; }
  int degree(int dir) const { return knots_[dir].degree(); }
  int numControl(int dir) const { return knots_[dir].numBasis(); }
  const Eigen::MatrixX3d& controlPoints() const { return P_; }
  Eigen::Index controlIndex(int i, int j) const { return i + static_cast<Eigen::Index>(numControl(0)) * j; }

  Eigen::Vector3d evaluate(double s, double t) const;
  /// Position and first derivatives S_s, S_t (either pointer may be null).
  Eigen::Vector3d evaluate(double s, double t, Eigen::Vector3d* Ss, Eigen::Vector3d* St) const;
  /// S_s × S_t (not normalised).
  Eigen::Vector3d normal(double s, double t) const;
  /// Batch: #points × 3 positions for #points × 2 parameters.
  Eigen::MatrixX3d evaluate(const Eigen::MatrixX2d& ST) const;

 private:
  std::array<KnotVector, 2> knots_;
  Eigen::MatrixX3d P_;
};

/// The six faces of the parameter box. Face f has parameter `direction(f)`
/// fixed at its lower (even f) or upper (odd f) end.
enum class VolumeFace { UMin = 0, UMax = 1, VMin = 2, VMax = 3, WMin = 4, WMax = 5 };

/// One knot span of each direction: a Bézier element.
struct BezierElement {
  Eigen::Vector3i span;    ///< knot span index s per direction (U[s] <= u < U[s+1])
  Eigen::Vector3i index;   ///< element number per direction, 0-based
  Eigen::Vector3d lower;   ///< parameter box corner
  Eigen::Vector3d upper;
  Eigen::Vector3d centre;  ///< (lower + upper) / 2 in parameter space
};

class BSplineVolume {
 public:
  BSplineVolume() = default;
  /// Throws Error(Usage) unless P has n_u*n_v*n_w rows.
  BSplineVolume(KnotVector u, KnotVector v, KnotVector w, Eigen::MatrixX3d controlPoints);
  /// The identity map x = (u,v,w): control points at the Greville abscissae.
  static BSplineVolume identity(KnotVector u, KnotVector v, KnotVector w);

  const KnotVector& knots(int dir) const { return knots_[dir]; }
  int degree(int dir) const { return knots_[dir].degree(); }
  int numControl(int dir) const { return knots_[dir].numBasis(); }
  Eigen::Index numControlPoints() const { return P_.rows(); }
  Eigen::Index controlIndex(int i, int j, int k) const {
    return i + static_cast<Eigen::Index>(numControl(0)) * (j + static_cast<Eigen::Index>(numControl(1)) * k);
  }
  const Eigen::MatrixX3d& controlPoints() const { return P_; }
  /// Replace the control points (same count). Throws Error(Usage) otherwise.
  void setControlPoints(Eigen::MatrixX3d P);
  /// Lower and upper corners of the parameter box.
  Eigen::Vector3d parameterMin() const;
  Eigen::Vector3d parameterMax() const;

  Eigen::Vector3d evaluate(const Eigen::Vector3d& u) const;
  /// Position and Jacobian J = [x_u x_v x_w] (J may be null). Parameters
  /// outside the box are clamped to it.
  Eigen::Vector3d evaluate(const Eigen::Vector3d& u, Eigen::Matrix3d* J) const;
  Eigen::Matrix3d jacobian(const Eigen::Vector3d& u) const;
  double detJacobian(const Eigen::Vector3d& u) const;
  /// det J / (|x_u| |x_v| |x_w|), in [−1, 1]; 0 where a column vanishes.
  double scaledJacobian(const Eigen::Vector3d& u) const;
  /// Batch evaluation of #points × 3 parameters: positions #points × 3 and,
  /// if detJ is non-null, det J per point.
  Eigen::MatrixX3d evaluate(const Eigen::MatrixX3d& U, Eigen::VectorXd* detJ = nullptr) const;

  /// Inserts knot t `times` times in direction dir (0,1,2); the map is unchanged.
  void insertKnot(int dir, double t, int times = 1);
  /// Raises the degree in direction dir by `by`; the map is unchanged.
  void elevateDegree(int dir, int by = 1);
  /// Uniform h-refinement: splits every knot span of every direction into
  /// `parts` equal pieces (simple new knots).
  void refine(int parts = 2);

  /// Boundary face as an exact B-spline surface whose control points are the
  /// outer layer of the control grid. Orientation: S_s × S_t points out of
  /// the volume wherever det J > 0. The face parameters (s,t) are
  ///   UMin: (w, v)  UMax: (v, w)   VMin: (u, w)  VMax: (w, u)
  ///   WMin: (v, u)  WMax: (u, v)
  /// i.e. the two remaining directions in cyclic order (v,w), (w,u), (u,v),
  /// swapped on the lower faces.
  BSplineSurface face(VolumeFace f) const;
  /// Parameters (u,v,w) of the volume at face parameters (s,t) of face f.
  Eigen::Vector3d faceToVolumeParameter(VolumeFace f, double s, double t) const;

  /// ∫ det J over the parameter box by Gauss–Legendre quadrature with
  /// ceil(3p/2) + 1 points per direction per span, exact for the polynomial
  /// det J (degree 3p − 1 in u). Signed volume of the image when det J > 0.
  double volume() const;

  /// All Bézier elements, u fastest then v then w (element index
  /// e_u + N_u*(e_v + N_v*e_w)).
  std::vector<BezierElement> elements() const;
  Eigen::Vector3i numElements() const;

 private:
  void applyAlongDirection(int dir, const Eigen::MatrixXd& M);

  std::array<KnotVector, 3> knots_;
  Eigen::MatrixX3d P_;
};

/// Direction (0 = u, 1 = v, 2 = w) fixed on face f.
inline int direction(VolumeFace f) { return static_cast<int>(f) / 2; }
/// True when face f is at the upper end of its direction.
inline bool isUpper(VolumeFace f) { return static_cast<int>(f) % 2 == 1; }

}  // namespace tet2spline::spline
