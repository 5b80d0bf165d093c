#pragma once
// Private to tet2spline::param: maps from the unit ball onto the unit cube
// [0,1]³ for the transport's sites (parameterize.cpp).
#include <Eigen/Core>

namespace tet2spline::detail {

/// A point of the unit ball mapped onto [0,1]³ preserving volume:
/// x = rω ↦ ½ + ½ r F(ω), F an equal-area map of the unit sphere onto the
/// surface of [−1,1]³. The cone over a surface element of [−1,1]³ at
/// distance 1 from the centre has volume t² dt dA, the ball's r² dr dω, so
/// with t = r and dA = (24/4π) dω the volume element is multiplied by the
/// constant 6/π (times 1/8 for the halving): 3/(4π), the cube's volume over
/// the ball's. On the cap over the face z = 1 with 0 <= y <= x, in polar
/// angle θ and azimuth φ about the face's axis: the cap's edge is
/// cos Θ(φ) = cos φ / √(1 + cos² φ), the cap's area between the azimuths 0
/// and φ is A(φ) = φ − asin(sin φ / √2), and the face point (X, sX) with
/// s = 12 A(φ)/π and X² = (1 − cos θ)/(1 − cos Θ(φ)) gives equal areas to
/// the wedge of rays through the face's centre up to s and to the part of
/// the cap within θ: X²/2 · ds against (1 − cos θ) dφ, each times π/6. The
/// other 47 pieces follow by the cube's symmetries, so pieces meet
/// continuously along the diagonals and the cube's edges. Positively
/// homogeneous of degree 1 like the radial stretch, Lipschitz, smooth away
/// from the planes |x_i| = |x_j| and the axes of the faces' centres. The
/// sphere goes onto the cube's surface.
Eigen::Vector3d equalVolumeBallToCube(const Eigen::Vector3d& x);

}  // namespace tet2spline::detail
