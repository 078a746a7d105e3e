#include <gshell/deform/synthetic_motion.h>

#include <gshell/error.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

namespace gshell {

namespace {

// The frame with the axes in `order` (long, middle, short).
MotionFrame frame_along(const Eigen::MatrixXd& V, std::array<int, 3> order, bool sort_all) {
  MotionFrame frame;
  if (V.cols() != 3) throw InputError("motion_frame: expected n x 3 positions (got " + std::to_string(V.cols()) + " columns)");
  if (V.rows() == 0) return frame;
  const Eigen::Vector3d lo = V.colwise().minCoeff().transpose(), hi = V.colwise().maxCoeff().transpose();
  const Eigen::Vector3d extent = hi - lo;
  // Stable, so ties (a square plane) keep the x, y, z order.
  std::stable_sort(order.begin() + (sort_all ? 0 : 1), order.end(),
                   [&](int a, int b) { return extent[a] > extent[b]; });
  frame.center = 0.5 * (lo + hi);
  frame.long_axis = order[0];
  frame.middle_axis = order[1];
  frame.short_axis = order[2];
  frame.length = extent[order[0]];
  return frame;
}

// A NaN angle gave NaN positions without a word; a frame's axis indexes V's columns.
void check_motion(const Eigen::MatrixXd& V, const MotionFrame& frame, double degrees, const char* what) {
  if (!std::isfinite(degrees)) throw InputError(std::string(what) + ": the angle must be a finite number of degrees");
  if (V.cols() != 3) throw InputError(std::string(what) + ": expected n x 3 positions");
  for (int axis : {frame.long_axis, frame.middle_axis, frame.short_axis})
    if (axis < 0 || axis > 2) throw InputError(std::string(what) + ": the frame's axes must be 0, 1 or 2");
  if (!frame.center.allFinite() || !std::isfinite(frame.length))
    throw InputError(std::string(what) + ": the frame's center and length must be finite");
}

} // namespace

MotionFrame motion_frame(const Eigen::MatrixXd& V) { return frame_along(V, {0, 1, 2}, true); }

MotionFrame motion_frame(const Eigen::MatrixXd& V, int long_axis) {
  if (long_axis < 0 || long_axis > 2) throw InputError("motion_frame: the axis must be 0, 1 or 2 (x, y, z)");
  std::array<int, 3> order{long_axis, (long_axis + 1) % 3, (long_axis + 2) % 3};
  if (order[1] > order[2]) std::swap(order[1], order[2]); // ties among the others in x, y, z order
  return frame_along(V, order, false);
}

Eigen::MatrixXd bend(const Eigen::MatrixXd& V, const MotionFrame& frame, double degrees, double band) {
  check_motion(V, frame, degrees, "bend");
  if (!std::isfinite(band)) throw InputError("bend: the band must be a finite number");
  const double angle = degrees * std::numbers::pi / 180.0;
  Eigen::MatrixXd out = V;
  band = std::clamp(band, 1e-6, 1.0);
  if (std::abs(angle) < 1e-12 || frame.length <= 0) return out;
  // Arc of radius R = bent length / angle, centred on the short axis at distance R from the
  // center; beyond the band the mesh continues along the arc's end tangents.
  const double half_band = 0.5 * band * frame.length;
  const double R = band * frame.length / angle;
  const int a = frame.long_axis, s = frame.short_axis;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    const double along = V(i, a) - frame.center[a], across = V(i, s) - frame.center[s];
    const double clamped = std::clamp(along, -half_band, half_band), beyond = along - clamped;
    const double phi = clamped / R;
    out(i, a) = frame.center[a] + (R - across) * std::sin(phi) + beyond * std::cos(phi);
    out(i, s) = frame.center[s] + R - (R - across) * std::cos(phi) + beyond * std::sin(phi);
  }
  return out;
}

Eigen::MatrixXd twist(const Eigen::MatrixXd& V, const MotionFrame& frame, double degrees) {
  check_motion(V, frame, degrees, "twist");
  const double angle = degrees * std::numbers::pi / 180.0;
  Eigen::MatrixXd out = V;
  if (frame.length <= 0) return out;
  const int a = frame.long_axis, m = frame.middle_axis, s = frame.short_axis;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    const double phi = angle * (V(i, a) - frame.center[a]) / frame.length;
    const double x = V(i, m) - frame.center[m], y = V(i, s) - frame.center[s];
    out(i, m) = frame.center[m] + std::cos(phi) * x - std::sin(phi) * y;
    out(i, s) = frame.center[s] + std::sin(phi) * x + std::cos(phi) * y;
  }
  return out;
}

double ramp(int k, int K) {
  if (K <= 0) return 1.0;
  const double t = std::clamp(static_cast<double>(k) / K, 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

} // namespace gshell
