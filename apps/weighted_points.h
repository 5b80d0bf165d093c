#pragma once
// The point-set format of `tet2spline transport` (and of the OT benchmark's
// --points): first line N, then N lines "x y z mass"; '#' starts a comment.
#include <Eigen/Core>
#include <string>

namespace tet2spline::cli {

struct WeightedPoints {
  Eigen::MatrixX3d points;
  Eigen::VectorXd masses;
};

/// Throws Error(Input) naming the file and line of the first problem:
/// unreadable file, a bad count, a line that is not four numbers, non-finite
/// coordinates, a mass that is not finite and > 0, fewer or more points than
/// announced.
WeightedPoints readWeightedPoints(const std::string& path);

}  // namespace tet2spline::cli
