#pragma once
// Internal: the small max-min problem of the untangler's local repair
// (untangle.cpp), here so that a test can hold it to the bits of the code
// it replaced.
#include <Eigen/Core>

namespace tet2spline::detail {

/// Largest t with A z + b >= t·e_tets, t <= 1, inside a box: one vertex's
/// (or one patch's) max-min problem of the local repair. Rows of `a` are
/// the constraints a·z + b > 0 over z = (d, t) with d the free coordinates'
/// displacement; z starts strictly feasible. Log-barrier path following
/// (τ from 1, ×8 while #rows/τ > gap, at most 1e9 at the default gap),
/// damped Newton inside (Armijo backtracking by halves). Returns z.
/// `products`: H and g by dense matrix products (for the patches' larger
/// problems) instead of sums over the rows (the single vertices' problems).
Eigen::VectorXd maxMinBarrier(const Eigen::MatrixXd& a, const Eigen::VectorXd& b, Eigen::VectorXd z,
                              bool products = false, double gap = 1e-7);

}  // namespace tet2spline::detail
