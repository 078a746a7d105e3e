#include <gshell/render/scene.h>

#include <gshell/error.h>

#ifdef GSHELL_HAVE_OSMESA
#include <GL/gl.h>
#include <GL/osmesa.h>
#endif

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

namespace gshell {

bool offscreen_rendering_available() {
#ifdef GSHELL_HAVE_OSMESA
  return true;
#else
  return false;
#endif
}

Eigen::MatrixXd scene_points(const Scene& scene) {
  Eigen::Index rows = 0;
  for (const auto& layer : scene.layers) rows += layer.V.rows();
  Eigen::MatrixXd points(rows, 3);
  Eigen::Index at = 0;
  for (const auto& layer : scene.layers) {
    points.middleRows(at, layer.V.rows()) = layer.V;
    at += layer.V.rows();
  }
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

Soup make_soup(const SurfaceLayer& layer) {
  const auto& V = layer.V;
  const auto& F = layer.F;
  const Eigen::Index m = F.rows();
  Eigen::MatrixXd face_normal(m, 3);
  Eigen::MatrixXd vertex_normal = Eigen::MatrixXd::Zero(V.rows(), 3);
  for (Eigen::Index f = 0; f < m; ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a); // length = 2 * area: area weighting for free
    face_normal.row(f) = n.normalized();
    for (int k = 0; k < 3; ++k) vertex_normal.row(F(f, k)) += n;
  }
  vertex_normal.rowwise().normalize();
  Soup soup;
  soup.position.reserve(9 * m);
  soup.normal.reserve(9 * m);
  soup.color.reserve(12 * m);
  for (Eigen::Index f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) {
      const int v = F(f, k);
      const Eigen::Vector3d n = layer.smooth ? Eigen::Vector3d(vertex_normal.row(v)) : Eigen::Vector3d(face_normal.row(f));
      Eigen::Vector3f c = layer.color;
      if (layer.face_colors.size() > 0) c = layer.face_colors.row(f).transpose();
      else if (layer.vertex_colors.size() > 0) c = layer.vertex_colors.row(v).transpose();
      for (int d = 0; d < 3; ++d) {
        soup.position.push_back(static_cast<float>(V(v, d)));
        soup.normal.push_back(std::isfinite(n[d]) ? static_cast<float>(n[d]) : 0.0f);
        soup.color.push_back(std::clamp(c[d], 0.0f, 1.0f));
      }
      soup.color.push_back(std::clamp(layer.opacity, 0.0f, 1.0f));
    }
  return soup;
}

void draw_soup(const Soup& soup) {
  glVertexPointer(3, GL_FLOAT, 0, soup.position.data());
  glNormalPointer(GL_FLOAT, 0, soup.normal.data());
  glColorPointer(4, GL_FLOAT, 0, soup.color.data());
  glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(soup.position.size() / 3));
}

struct ContextDeleter {
  void operator()(osmesa_context* context) const { OSMesaDestroyContext(context); }
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
  std::unique_ptr<osmesa_context, ContextDeleter> context(OSMesaCreateContextAttribs(attributes, nullptr));
  if (!context) throw std::runtime_error("render: cannot create an OSMesa context");
  std::vector<unsigned char> buffer(static_cast<size_t>(w) * h * 4);
  if (!OSMesaMakeCurrent(context.get(), buffer.data(), GL_UNSIGNED_BYTE, w, h))
    throw std::runtime_error("render: cannot bind the OSMesa buffer");
  OSMesaPixelStore(OSMESA_Y_UP, 0); // row 0 = top, like Image

  glViewport(0, 0, w, h);
  glClearColor(options.background.x(), options.background.y(), options.background.z(), 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);

  glMatrixMode(GL_PROJECTION);
  const Eigen::Matrix4d projection = camera.projection_matrix(static_cast<double>(w) / h);
  glLoadMatrixd(projection.data());
  glMatrixMode(GL_MODELVIEW);
  glLoadIdentity();

  // Headlight: a directional light along the view axis, fixed in eye space.
  const GLfloat light_direction[] = {0, 0, 1, 0};
  const GLfloat ambient[] = {options.ambient, options.ambient, options.ambient, 1};
  const GLfloat diffuse[] = {options.diffuse, options.diffuse, options.diffuse, 1};
  const GLfloat none[] = {0, 0, 0, 1};
  glLightfv(GL_LIGHT0, GL_POSITION, light_direction);
  glLightfv(GL_LIGHT0, GL_AMBIENT, ambient);
  glLightfv(GL_LIGHT0, GL_DIFFUSE, diffuse);
  glLightfv(GL_LIGHT0, GL_SPECULAR, none);
  glLightModelfv(GL_LIGHT_MODEL_AMBIENT, none);
  glLightModeli(GL_LIGHT_MODEL_TWO_SIDE, GL_TRUE); // open surfaces look the same from both sides
  glMaterialfv(GL_FRONT_AND_BACK, GL_SPECULAR, none);
  glMaterialfv(GL_FRONT_AND_BACK, GL_EMISSION, none);
  glEnable(GL_LIGHTING);
  glEnable(GL_LIGHT0);
  glEnable(GL_COLOR_MATERIAL);
  glColorMaterial(GL_FRONT_AND_BACK, GL_AMBIENT_AND_DIFFUSE);
  glShadeModel(GL_SMOOTH);

  const Eigen::Matrix4d view = camera.view_matrix();
  glLoadMatrixd(view.data());
  if (scene.clip_plane) {
    const GLdouble plane[4] = {(*scene.clip_plane)[0], (*scene.clip_plane)[1], (*scene.clip_plane)[2],
                               (*scene.clip_plane)[3]};
    glClipPlane(GL_CLIP_PLANE0, plane); // taken in world coordinates: the view matrix is current
    glEnable(GL_CLIP_PLANE0);
  }

  glEnableClientState(GL_VERTEX_ARRAY);
  glEnableClientState(GL_NORMAL_ARRAY);
  glEnableClientState(GL_COLOR_ARRAY);
  std::vector<Soup> translucent;
  for (const auto& layer : scene.layers) {
    if (layer.opacity >= 1.0f) draw_soup(make_soup(layer));
    else if (layer.opacity > 0.0f) translucent.push_back(make_soup(layer));
  }
  if (!translucent.empty()) {
    // Blended after every opaque surface, without writing depth; back faces before front faces
    // is the cheap ordering that is right for closed, convex-ish layers.
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glDepthMask(GL_FALSE);
    glEnable(GL_CULL_FACE);
    for (GLenum cull : {GL_FRONT, GL_BACK}) {
      glCullFace(cull);
      for (const auto& soup : translucent) draw_soup(soup);
    }
    glDisable(GL_CULL_FACE);
    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
  }
  glFinish();
  if (glGetError() != GL_NO_ERROR) throw std::runtime_error("render: OpenGL error");

  Image big(w, h);
  for (size_t i = 0, n = static_cast<size_t>(w) * h; i < n; ++i)
    std::copy_n(buffer.data() + 4 * i, 3, big.rgb.data() + 3 * i);
  OSMesaMakeCurrent(nullptr, nullptr, GL_UNSIGNED_BYTE, 0, 0);
  return downsample(big, ss);
#endif
}

} // namespace gshell
