#pragma once
// Offscreen rendering of shaded triangle surfaces (OSMesa: Mesa's software OpenGL, no display
// and no GPU needed). Lambert + ambient shading with a headlight: a surface facing the camera
// shows exactly its own color (ambient + diffuse = 1), which tests rely on.
#include <gshell/render/camera.h>
#include <gshell/render/image.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <optional>
#include <vector>

namespace gshell {

/// One triangle surface of a scene. Color precedence: face_colors, then vertex_colors, then color.
struct SurfaceLayer {
  Eigen::MatrixXd V;               ///< n x 3 positions
  Eigen::MatrixXi F;               ///< m x 3 vertex ids
  Eigen::MatrixXf face_colors;     ///< m x 3 RGB in [0,1], or empty
  Eigen::MatrixXf vertex_colors;   ///< n x 3 RGB in [0,1], or empty
  Eigen::Vector3f color{0.8f, 0.8f, 0.8f};
  float opacity = 1;               ///< < 1: blended over the opaque layers, back faces first
  bool smooth = true;              ///< interpolate area-weighted vertex normals (else flat faces)
  /// Uniform color of back faces (the inside of a closed surface); unset: same as the front.
  std::optional<Eigen::Vector3f> back_color;
};

struct Scene {
  std::vector<SurfaceLayer> layers;
  /// Cut-away: only points with (a, b, c) . x + d >= 0 are drawn (world coordinates).
  std::optional<Eigen::Vector4d> clip_plane;
};

struct RenderOptions {
  int width = 800, height = 600;                ///< output size in pixels
  int supersample = 2;                          ///< render k times larger and box-filter down (anti-aliasing)
  Eigen::Vector3f background{1.0f, 1.0f, 1.0f};
  float ambient = 0.3f, diffuse = 0.7f;         ///< headlight; a face seen head-on shows its exact color
};

/// True when the library was built with OSMesa (otherwise render_scene throws).
bool offscreen_rendering_available();

/// Renders the scene seen by `camera` (whose projection is set up for width / height).
/// \throws InputError on a non-positive image size, a layer with a bad shape, index, color count
///         or a non-finite position, or when the library was built without OSMesa;
///         std::runtime_error if the GL context fails.
Image render_scene(const Scene& scene, const Camera& camera, const RenderOptions& options);

/// All vertices of all layers stacked, without those the clip plane cuts away (for framing).
Eigen::MatrixXd scene_points(const Scene& scene);

} // namespace gshell
