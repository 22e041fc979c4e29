// Rotations: the one place for the paper's conventions (DESIGN.md, "Frames and notation").
//
// C_a_b maps coordinates in frame b to frame a: p_a = C_a_b * p_b. The paper's Euler set is
// "2-1-3" (eq. 9): C = R3(psi) * R1(phi) * R2(theta) with the passive (frame) rotations R1, R2,
// R3 below; roll phi about x, pitch theta about y, yaw psi about z. Angles are radians unless
// a name ends in _deg. Internally use matrices or quaternions; Euler angles are for people.
// No heap, no exceptions: usable on the flyer.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace mfns {

inline constexpr double kPi = 3.14159265358979323846;
constexpr double DegToRad(double deg) { return deg * (kPi / 180.0); }
constexpr double RadToDeg(double rad) { return rad * (180.0 / kPi); }

// The one angle wrap (issue 15): a (rad) to (-pi, pi], a_deg to (-180, 180]. A difference of
// exactly half a turn reads +pi (+180) whichever side it came from, so that two tools comparing
// the same angles agree. Non-finite input is returned unchanged (NaN stays NaN).
double WrapPi(double a);
double Wrap180Deg(double a_deg);

// The paper's 2-1-3 Euler set, radians. phi in [-pi/2, pi/2] on output of MatrixToEuler.
struct EulerAngles {
  double phi = 0.0;    // roll, about x
  double theta = 0.0;  // pitch, about y
  double psi = 0.0;    // yaw, about z
};

// Frame (passive) rotations by angle a about x (1), y (2), z (3):
// R1(a) = [[1,0,0],[0,c,s],[0,-s,c]], R2(a) = [[c,0,-s],[0,1,0],[s,0,c]],
// R3(a) = [[c,s,0],[-s,c,0],[0,0,1]].
Eigen::Matrix3d R1(double a);
Eigen::Matrix3d R2(double a);
Eigen::Matrix3d R3(double a);

// C = R3(psi) * R1(phi) * R2(theta) (eq. 9).
Eigen::Matrix3d EulerToMatrix(const EulerAngles& e);

// Inverse of EulerToMatrix on the principal branch phi in [-pi/2, pi/2]:
// phi = asin(-C21), theta = atan2(C20, C22), psi = atan2(C01, C11). At |phi| = pi/2 (gimbal
// lock) theta and psi are not separable; psi is then set to 0 and theta carries the sum.
EulerAngles MatrixToEuler(const Eigen::Matrix3d& C);

Eigen::Quaterniond EulerToQuaternion(const EulerAngles& e);
EulerAngles QuaternionToEuler(const Eigen::Quaterniond& q);

// [v]x, the cross-product matrix: Skew(a) * b == a.cross(b).
Eigen::Matrix3d Skew(const Eigen::Vector3d& v);

// Small-angle frame rotation (eqs. A2, A3): for small Euler angles a = (phi, theta, psi)
// (or the paper's alpha, beta, gamma), C ~= I - [a]x = [[1, psi, -theta], [-psi, 1, phi],
// [theta, -phi, 1]], exact to first order in the angles.
Eigen::Matrix3d SmallAngleMatrix(const Eigen::Vector3d& angles);

// Exp/Log of SO(3), active convention: Exp(w) rotates vectors by |w| about w/|w|, so the frame
// rotation by a about unit axis n is Exp(-a * n). Log returns |w| <= pi.
Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& w);
Eigen::Vector3d LogSO3(const Eigen::Matrix3d& C);

// Right Jacobian of SO(3): Exp(w + dw) = Exp(w) Exp(J_r(w) dw) to first order in dw; the left
// one is J_r(-w): Exp(w + dw) = Exp(J_r(-w) dw) Exp(w). A Jacobian taken with respect to a
// rotation perturbation at the current rotation becomes one with respect to the parameter w
// through it (exact at every w, not only at w = 0).
Eigen::Matrix3d RightJacobianSO3(const Eigen::Vector3d& w);

// True when C^T C = I and det C = +1 within tol (max abs element error).
bool IsRotation(const Eigen::Matrix3d& C, double tol = 1e-9);

// Nearest rotation matrix (polar decomposition through SVD) to an almost-orthonormal M.
Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& M);

}  // namespace mfns
