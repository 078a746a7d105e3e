#pragma once
// Where the camera looks from, framed automatically around the model's bounding box.
#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>

namespace gshell {

/// View direction as the direction from the model to the eye, in a y-up world:
/// eye direction = (cos(el) sin(az), sin(el), cos(el) cos(az)). azimuth 0 / elevation 0 looks at
/// the model from +z ("front"); azimuth 90 from +x ("right"); elevation 90 from +y ("top").
struct ViewDirection {
  double azimuth_deg = 30;   ///< degrees about +y, counter-clockwise seen from above
  double elevation_deg = 20; ///< degrees above the xz plane, in [-90, 90]
};

/// Parses "front", "back", "left", "right", "top", "bottom", "iso" (az 30, el 20) or "AZ,EL"
/// in degrees.
/// \throws InputError naming the view on anything else (also a non-finite angle or an elevation
///         outside [-90, 90]).
ViewDirection parse_view(const std::string& text);

enum class Projection { Perspective, Orthographic };

struct Camera {
  Eigen::Vector3d eye, target, up;   ///< up is orthogonal to (target - eye), unit length
  Projection projection = Projection::Perspective;
  double fov_y_deg = 30;             ///< vertical field of view (perspective)
  double half_height = 1;            ///< half the visible height at the target (orthographic), model units
  double near_plane = 0.01, far_plane = 100;

  Eigen::Vector3d forward() const { return (target - eye).normalized(); }
  /// World -> eye coordinates (OpenGL convention: the camera looks down -z).
  Eigen::Matrix4d view_matrix() const;
  /// Eye -> clip coordinates for a viewport of the given width / height.
  Eigen::Matrix4d projection_matrix(double aspect) const;
};

/// A camera looking from `view` at the points (N x 3), centred on their extent across the view
/// and far enough that all of them fit the viewport (aspect = width / height) with `margin`
/// (fraction of the half-size) to spare. Up is world +y, except straight top/bottom views, which
/// use -z / +z.
/// \throws InputError when `points` is empty or not N x 3, or aspect is not positive and finite.
Camera frame_camera(const Eigen::MatrixXd& points, const ViewDirection& view, double aspect,
                    Projection projection = Projection::Perspective, double margin = 0.05);

/// The unit vector from the model towards the eye for `view`.
Eigen::Vector3d eye_direction(const ViewDirection& view);

} // namespace gshell
