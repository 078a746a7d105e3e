#pragma once
// Smooth synthetic deformations of a base mesh for tests, benchmarks and demos (`gshell animate`).
#include <gshell/eigen_abi.h>
#include <Eigen/Core>

namespace gshell {

/// Axes of the rest mesh's bounding box, sorted by extent: long (bend/twist axis), middle, short.
struct MotionFrame {
  Eigen::Vector3d center = Eigen::Vector3d::Zero(); ///< bounding box center
  int long_axis = 0, middle_axis = 1, short_axis = 2;
  double length = 0;                                ///< bounding box extent along the long axis
};
/// \throws InputError unless V is n x 3.
MotionFrame motion_frame(const Eigen::MatrixXd& V);
/// The same with the long (bend/twist) axis chosen (0, 1, 2: x, y, z), the other two sorted by
/// extent. \throws InputError for another axis.
MotionFrame motion_frame(const Eigen::MatrixXd& V, int long_axis);

/// Bends the long axis into a circular arc of total angle `degrees` (rotation about the middle
/// axis, the mesh curling towards +short axis for positive angles, the other way for negative).
/// Only the central `band` fraction of the long axis bends (1 = all of it; smaller values give a
/// fold: an arc of radius band * length / angle between two straight, tangent parts).
/// The plane through the center across the long axis stays put; lengths along the long axis are
/// kept on the bounding box's mid-plane (short coordinate = center), so a flat mesh is bent
/// isometrically. \throws InputError (as twist) for a non-finite angle or band, V not n x 3, or a
/// frame with an axis outside 0..2 or a non-finite center or length.
Eigen::MatrixXd bend(const Eigen::MatrixXd& V, const MotionFrame& frame, double degrees, double band = 1.0);

/// Twists about the long axis through the center: the angle grows linearly along the axis from
/// -degrees/2 at one end of the bounding box to +degrees/2 at the other.
Eigen::MatrixXd twist(const Eigen::MatrixXd& V, const MotionFrame& frame, double degrees);

/// Smooth ramp for frame k of K (k = 1..K): smoothstep(k / K), so frame K reaches the full angle,
/// the motion starts and ends with zero speed, and frame 0 (not written) would be the rest pose.
double ramp(int k, int K);

} // namespace gshell
