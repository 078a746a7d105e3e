#include <gshell/render/camera.h>

#include <gshell/error.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

namespace gshell {
namespace {
constexpr double kPi = 3.14159265358979323846;
double radians(double deg) { return deg * kPi / 180.0; }
} // namespace

ViewDirection parse_view(const std::string& text) {
  std::string t = text;
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (t == "front") return {0, 0};
  if (t == "back") return {180, 0};
  if (t == "right") return {90, 0};
  if (t == "left") return {-90, 0};
  if (t == "top") return {0, 90};
  if (t == "bottom") return {0, -90};
  if (t == "iso") return {30, 20};
  std::istringstream in(t);
  double az = 0, el = 0;
  char comma = 0;
  if (in >> az >> comma >> el && comma == ',' && (in >> std::ws).eof() && std::isfinite(az) && std::isfinite(el) &&
      el >= -90 && el <= 90)
    return {az, el};
  throw InputError("view " + text +
                   ": expected front|back|left|right|top|bottom|iso or AZIMUTH,ELEVATION in degrees (elevation in [-90,90])");
}

Eigen::Vector3d eye_direction(const ViewDirection& view) {
  const double az = radians(view.azimuth_deg), el = radians(view.elevation_deg);
  return Eigen::Vector3d(std::cos(el) * std::sin(az), std::sin(el), std::cos(el) * std::cos(az)).normalized();
}

Eigen::Matrix4d Camera::view_matrix() const {
  const Eigen::Vector3d f = forward();
  const Eigen::Vector3d s = f.cross(up).normalized();
  const Eigen::Vector3d u = s.cross(f);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<1, 3>(0, 0) = s.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -s.dot(eye);
  m(1, 3) = -u.dot(eye);
  m(2, 3) = f.dot(eye);
  return m;
}

Eigen::Matrix4d Camera::projection_matrix(double aspect) const {
  Eigen::Matrix4d p = Eigen::Matrix4d::Zero();
  const double n = near_plane, f = far_plane;
  if (projection == Projection::Perspective) {
    const double t = 1.0 / std::tan(radians(fov_y_deg) / 2);
    p(0, 0) = t / aspect;
    p(1, 1) = t;
    p(2, 2) = (f + n) / (n - f);
    p(2, 3) = 2 * f * n / (n - f);
    p(3, 2) = -1;
  } else {
    p(0, 0) = 1.0 / (half_height * aspect);
    p(1, 1) = 1.0 / half_height;
    p(2, 2) = -2.0 / (f - n);
    p(2, 3) = -(f + n) / (f - n);
    p(3, 3) = 1;
  }
  return p;
}

Camera frame_camera(const Eigen::MatrixXd& points, const ViewDirection& view, double aspect, Projection projection,
                    double margin) {
  if (points.rows() == 0 || points.cols() != 3)
    throw InputError("frame_camera: points must be a non-empty n x 3 matrix");
  if (!(aspect > 0) || !std::isfinite(aspect)) throw InputError("frame_camera: aspect must be a finite number > 0");
  const Eigen::Vector3d dir = eye_direction(view);
  Eigen::Vector3d up(0, 1, 0);
  if (std::abs(dir.dot(up)) > 0.999) up = view.elevation_deg > 0 ? Eigen::Vector3d(0, 0, -1) : Eigen::Vector3d(0, 0, 1);
  up = (up - up.dot(dir) * dir).normalized();
  const Eigen::Vector3d right = up.cross(dir); // screen x (dir points to the eye)

  // Extent of the points in screen-aligned coordinates (right, up, towards the eye).
  Eigen::Matrix3d basis;
  basis << right.transpose(), up.transpose(), dir.transpose();
  const Eigen::MatrixXd local = points * basis.transpose();
  const Eigen::Vector3d lo = local.colwise().minCoeff(), hi = local.colwise().maxCoeff();
  const Eigen::Vector3d mid = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
  // Points that all coincide still get a camera; otherwise the extent sets the scale, whatever the
  // units (no absolute floor: a mesh of size 1e-40 is framed like one of size 1).
  const double extent = half.maxCoeff() > 0 ? half.maxCoeff() : 1.0;

  Camera cam;
  cam.projection = projection;
  cam.up = up;
  cam.target = basis.transpose() * mid;
  // Half the visible height needed at the target's depth (orthographic) or at the nearest depth
  // (perspective: nearer points look bigger, so fitting them there is conservative).
  const double need = (1 + margin) * std::max({half.y(), half.x() / aspect, 1e-3 * extent});
  cam.half_height = need;
  double distance;
  if (projection == Projection::Perspective) {
    const double t = std::tan(radians(cam.fov_y_deg) / 2);
    distance = half.z() + need / t;
  } else {
    distance = half.z() + 2 * extent;
  }
  cam.eye = cam.target + distance * dir;
  cam.near_plane = std::max(distance - half.z() - 0.01 * extent, 1e-3 * distance);
  cam.far_plane = distance + half.z() + 0.01 * extent;
  return cam;
}

} // namespace gshell
