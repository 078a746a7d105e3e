#include <gshell/render/scene.h>

#include <gshell/error.h>

#include "render/box_filter.h"
#include "render/osmesa_library.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

namespace gshell {

bool offscreen_rendering_available() {
#ifdef GSHELL_HAVE_OSMESA
  return detail::osmesa_library() != nullptr;
#else
  return false;
#endif
}

Eigen::MatrixXd scene_points(const Scene& scene) {
  Eigen::Index rows = 0;
  for (const auto& layer : scene.layers) rows += layer.V.rows();
  Eigen::MatrixXd points(rows, 3);
  Eigen::Index at = 0;
  for (const auto& layer : scene.layers)
    for (Eigen::Index i = 0; i < layer.V.rows(); ++i) {
      const Eigen::Vector3d p = layer.V.row(i);
      if (scene.clip_plane && scene.clip_plane->head<3>().dot(p) + (*scene.clip_plane)[3] < 0) continue;
      points.row(at++) = p;
    }
  points.conservativeResize(at, 3);
  return points;
}

namespace {

void check_layer(const SurfaceLayer& layer, size_t index) {
  const std::string name = "render layer " + std::to_string(index);
  if (layer.V.cols() != 3 || (layer.F.rows() > 0 && layer.F.cols() != 3))
    throw InputError(name + ": positions and faces must have 3 columns");
  if (layer.F.size() > 0 && (layer.F.minCoeff() < 0 || layer.F.maxCoeff() >= layer.V.rows()))
    throw InputError(name + ": face index out of range");
  if (layer.face_colors.size() > 0 && (layer.face_colors.rows() != layer.F.rows() || layer.face_colors.cols() != 3))
    throw InputError(name + ": face colors must be one RGB row per face");
  if (layer.vertex_colors.size() > 0 && (layer.vertex_colors.rows() != layer.V.rows() || layer.vertex_colors.cols() != 3))
    throw InputError(name + ": vertex colors must be one RGB row per vertex");
  if (!layer.V.allFinite()) throw InputError(name + ": non-finite vertex position");
}

#ifdef GSHELL_HAVE_OSMESA

// Triangle soup of one layer: 3 corners per face, each with position, normal and RGBA color.
struct Soup {
  std::vector<float> position, normal, color;
};

/// OpenGL works in float (largest 3.4e38, smallest normal 1.2e-38): positions and normals are
/// handed over in a frame centred on the camera's target and scaled by its distance, where the
/// scene's coordinates are of order 1 whatever the model's units (gshell accepts up to 1e75).
struct UnitFrame {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  double scale = 1;
  Eigen::Vector3d operator()(const Eigen::Vector3d& world) const { return (world - origin) * scale; }
};

Soup make_soup(const SurfaceLayer& layer, const UnitFrame& frame) {
  const Eigen::MatrixXd V = (layer.V.rowwise() - frame.origin.transpose()) * frame.scale;
  const auto& F = layer.F;
  const Eigen::Index m = F.rows();
  Eigen::MatrixX3f face_normal(m, 3);
  Eigen::MatrixX3f vertex_normal = Eigen::MatrixX3f::Zero(V.rows(), 3);
  for (Eigen::Index f = 0; f < m; ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    const Eigen::Vector3f n = (b - a).cross(c - a).cast<float>(); // length = 2 * area: area weighting for free
    const float length = n.norm();
    face_normal.row(f) = length > 0 ? Eigen::RowVector3f(n.transpose() / length) : Eigen::RowVector3f::Zero();
    for (int k = 0; k < 3; ++k) vertex_normal.row(F(f, k)) += n.transpose();
  }
  for (Eigen::Index v = 0; v < vertex_normal.rows(); ++v) {
    const float length = vertex_normal.row(v).norm();
    if (length > 0) vertex_normal.row(v) /= length;
  }
  const bool by_face = layer.face_colors.size() > 0, by_vertex = !by_face && layer.vertex_colors.size() > 0;
  const float alpha = std::clamp(layer.opacity, 0.0f, 1.0f);
  Soup soup;
  soup.position.resize(9 * m);
  soup.normal.resize(9 * m);
  soup.color.resize(12 * m);
  float* position = soup.position.data();
  float* normal = soup.normal.data();
  float* color = soup.color.data();
  for (Eigen::Index f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) {
      const int v = F(f, k);
      for (int d = 0; d < 3; ++d) {
        *position++ = static_cast<float>(V(v, d));
        *normal++ = layer.smooth ? vertex_normal(v, d) : face_normal(f, d);
        const float c = by_face ? layer.face_colors(f, d) : by_vertex ? layer.vertex_colors(v, d) : layer.color[d];
        *color++ = std::clamp(c, 0.0f, 1.0f);
      }
      *color++ = alpha;
    }
  return soup;
}

void draw_soup(const detail::OSMesaLibrary& gl, const Soup& soup, const std::optional<Eigen::Vector3f>& back_color) {
  if (back_color) {
    const GLfloat back[] = {(*back_color)[0], (*back_color)[1], (*back_color)[2], soup.color.empty() ? 1.0f : soup.color[3]};
    gl.ColorMaterial(GL_FRONT, GL_AMBIENT_AND_DIFFUSE);
    gl.Materialfv(GL_BACK, GL_AMBIENT_AND_DIFFUSE, back);
  } else {
    gl.ColorMaterial(GL_FRONT_AND_BACK, GL_AMBIENT_AND_DIFFUSE);
  }
  gl.VertexPointer(3, GL_FLOAT, 0, soup.position.data());
  gl.NormalPointer(GL_FLOAT, 0, soup.normal.data());
  gl.ColorPointer(4, GL_FLOAT, 0, soup.color.data());
  gl.DrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(soup.position.size() / 3));
}

struct ContextDeleter {
  const detail::OSMesaLibrary* gl;
  void operator()(osmesa_context* context) const { gl->OSMesaDestroyContext(context); }
};

#endif

} // namespace

Image render_scene(const Scene& scene, const Camera& camera, const RenderOptions& options) {
  if (options.width <= 0 || options.height <= 0 || options.supersample < 1)
    throw InputError("render: image size must be positive");
  for (size_t i = 0; i < scene.layers.size(); ++i) check_layer(scene.layers[i], i);
#ifndef GSHELL_HAVE_OSMESA
  (void)camera;
  throw InputError("render: gshell was built without OSMesa (install libosmesa6-dev and rebuild)");
#else
  // Keep the supersampled buffer inside OSMesa's viewport limit.
  int ss = options.supersample;
  while (ss > 1 && std::max(options.width, options.height) * ss > 16384) --ss;
  const int w = options.width * ss, h = options.height * ss;

  const int attributes[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 24, OSMESA_PROFILE, OSMESA_COMPAT_PROFILE, 0};
  std::string why;
  const detail::OSMesaLibrary* library = detail::osmesa_library(&why);
  if (!library) throw InputError("render: " + why); // as when built without it: the setup, not a bug
  const detail::OSMesaLibrary& gl = *library;
  std::unique_ptr<osmesa_context, ContextDeleter> context(gl.OSMesaCreateContextAttribs(attributes, nullptr), ContextDeleter{&gl});
  if (!context) throw std::runtime_error("render: cannot create an OSMesa context");
  std::vector<unsigned char> buffer(static_cast<size_t>(w) * h * 4);
  if (!gl.OSMesaMakeCurrent(context.get(), buffer.data(), GL_UNSIGNED_BYTE, w, h))
    throw std::runtime_error("render: cannot bind the OSMesa buffer");
  gl.OSMesaPixelStore(OSMESA_Y_UP, 0); // row 0 = top, like Image

  gl.Viewport(0, 0, w, h);
  gl.ClearColor(options.background.x(), options.background.y(), options.background.z(), 1.0f);
  gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthFunc(GL_LEQUAL);

  UnitFrame frame;
  Camera unit_camera = camera; // the same view of the scene in `frame`
  if (const double distance = (camera.eye - camera.target).norm(); distance > 0 && std::isfinite(distance)) {
    frame = {camera.target, 1 / distance};
    unit_camera.eye = frame(camera.eye);
    unit_camera.target = Eigen::Vector3d::Zero();
    unit_camera.half_height *= frame.scale;
    unit_camera.near_plane *= frame.scale;
    unit_camera.far_plane *= frame.scale;
  }

  gl.MatrixMode(GL_PROJECTION);
  const Eigen::Matrix4d projection = unit_camera.projection_matrix(static_cast<double>(w) / h);
  gl.LoadMatrixd(projection.data());
  gl.MatrixMode(GL_MODELVIEW);
  gl.LoadIdentity();

  // Headlight: a directional light along the view axis, fixed in eye space.
  const GLfloat light_direction[] = {0, 0, 1, 0};
  const GLfloat ambient[] = {options.ambient, options.ambient, options.ambient, 1};
  const GLfloat diffuse[] = {options.diffuse, options.diffuse, options.diffuse, 1};
  const GLfloat none[] = {0, 0, 0, 1};
  gl.Lightfv(GL_LIGHT0, GL_POSITION, light_direction);
  gl.Lightfv(GL_LIGHT0, GL_AMBIENT, ambient);
  gl.Lightfv(GL_LIGHT0, GL_DIFFUSE, diffuse);
  gl.Lightfv(GL_LIGHT0, GL_SPECULAR, none);
  gl.LightModelfv(GL_LIGHT_MODEL_AMBIENT, none);
  gl.LightModeli(GL_LIGHT_MODEL_TWO_SIDE, GL_TRUE); // open surfaces look the same from both sides
  gl.Materialfv(GL_FRONT_AND_BACK, GL_SPECULAR, none);
  gl.Materialfv(GL_FRONT_AND_BACK, GL_EMISSION, none);
  gl.Enable(GL_LIGHTING);
  gl.Enable(GL_LIGHT0);
  gl.Enable(GL_COLOR_MATERIAL);
  gl.ColorMaterial(GL_FRONT_AND_BACK, GL_AMBIENT_AND_DIFFUSE);
  gl.ShadeModel(GL_SMOOTH);

  const Eigen::Matrix4d view = unit_camera.view_matrix();
  gl.LoadMatrixd(view.data());
  if (scene.clip_plane) {
    // n.x + d = 0 with x = origin + x' / scale  <=>  n.x' + scale (n.origin + d) = 0
    const Eigen::Vector4d& c = *scene.clip_plane;
    const GLdouble plane[4] = {c[0], c[1], c[2], frame.scale * (c.head<3>().dot(frame.origin) + c[3])};
    gl.ClipPlane(GL_CLIP_PLANE0, plane); // taken in world coordinates: the view matrix is current
    gl.Enable(GL_CLIP_PLANE0);
  }

  gl.EnableClientState(GL_VERTEX_ARRAY);
  gl.EnableClientState(GL_NORMAL_ARRAY);
  gl.EnableClientState(GL_COLOR_ARRAY);
  std::vector<std::pair<Soup, std::optional<Eigen::Vector3f>>> translucent;
  for (const auto& layer : scene.layers) {
    if (layer.opacity >= 1.0f) draw_soup(gl, make_soup(layer, frame), layer.back_color);
    else if (layer.opacity > 0.0f) translucent.emplace_back(make_soup(layer, frame), layer.back_color);
  }
  if (!translucent.empty()) {
    // Blended after every opaque surface, without writing depth; back faces before front faces
    // is the cheap ordering that is right for closed, convex-ish layers.
    gl.Enable(GL_BLEND);
    gl.BlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    gl.DepthMask(GL_FALSE);
    gl.Enable(GL_CULL_FACE);
    for (GLenum cull : {GL_FRONT, GL_BACK}) {
      gl.CullFace(cull);
      for (const auto& [soup, back_color] : translucent) draw_soup(gl, soup, back_color);
    }
    gl.Disable(GL_CULL_FACE);
    gl.DepthMask(GL_TRUE);
    gl.Disable(GL_BLEND);
  }
  gl.Finish();
  if (gl.GetError() != GL_NO_ERROR) throw std::runtime_error("render: OpenGL error");

  gl.OSMesaMakeCurrent(nullptr, nullptr, GL_UNSIGNED_BYTE, 0, 0);
  // Box filter straight from the RGBA buffer: one pass over the big image.
  Image image(options.width, options.height);
  detail::box_filter(buffer.data(), w, 4, ss, image);
  return image;
#endif
}

} // namespace gshell
