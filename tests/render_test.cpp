// Rendering checked against analytic expectations: silhouette areas, Lambert shading of planes,
// color bar values, framing, text, and the shell stretch colors.
#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/io/tet_mesh_io.h>
#include <gshell/io/write_mesh.h>
#include <gshell/quality/stretch.h>
#include <gshell/quality/shell_metrics.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/render/annotate.h>
#include <gshell/render/camera.h>
#include <gshell/render/color_map.h>
#include <gshell/render/figure.h>
#include <gshell/render/image.h>
#include <gshell/render/scene.h>
#include <gshell/render/shell_render.h>

#include "shell_fixtures.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

using namespace gshell;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A latitude/longitude sphere fine enough that its silhouette polygon is within 0.1% of the circle.
void uv_sphere(int rings, int segments, double r, Eigen::MatrixXd& V, Eigen::MatrixXi& F) {
  V.resize(2 + (rings - 1) * segments, 3);
  V.row(0) << 0, 0, r;
  V.row(1) << 0, 0, -r;
  for (int i = 1; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const double th = kPi * i / rings, ph = 2 * kPi * j / segments;
      V.row(2 + (i - 1) * segments + j) << r * std::sin(th) * std::cos(ph), r * std::sin(th) * std::sin(ph), r * std::cos(th);
    }
  auto id = [&](int i, int j) { return 2 + (i - 1) * segments + (j % segments); };
  std::vector<Eigen::Vector3i> faces;
  for (int j = 0; j < segments; ++j) {
    faces.emplace_back(0, id(1, j), id(1, j + 1));
    faces.emplace_back(1, id(rings - 1, j + 1), id(rings - 1, j));
    for (int i = 1; i + 1 < rings; ++i) {
      faces.emplace_back(id(i, j), id(i + 1, j), id(i + 1, j + 1));
      faces.emplace_back(id(i, j), id(i + 1, j + 1), id(i, j + 1));
    }
  }
  F.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (size_t f = 0; f < faces.size(); ++f) F.row(static_cast<Eigen::Index>(f)) = faces[f].transpose();
}

// Square [-h,h]^2 in the z = 0 plane, normal +z.
void square(double h, Eigen::MatrixXd& V, Eigen::MatrixXi& F) {
  V.resize(4, 3);
  V << -h, -h, 0, h, -h, 0, h, h, 0, -h, h, 0;
  F.resize(2, 3);
  F << 0, 1, 2, 0, 2, 3;
}

std::array<int, 3> pixel(const Image& image, int x, int y) {
  const auto* p = image.at(x, y);
  return {p[0], p[1], p[2]};
}

void expect_color(const Image& image, int x, int y, const Eigen::Vector3f& rgb, int tolerance, const std::string& what) {
  const auto p = pixel(image, x, y);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(p[c], 255.0 * rgb[c], tolerance) << what << " channel " << c << " at (" << x << "," << y << ")";
}

#define REQUIRE_RENDERER()                                                                                            \
  if (!offscreen_rendering_available()) GTEST_SKIP() << "built without OSMesa"

} // namespace

TEST(Render, SphereSilhouetteAreaMatchesPiRSquared) {
  REQUIRE_RENDERER();
  const double r = 0.8;
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  uv_sphere(96, 192, r, V, F);
  SurfaceLayer layer{V, F};
  layer.color = Eigen::Vector3f::Zero(); // black on white: darkness = coverage
  Scene scene;
  scene.layers.push_back(layer);
  for (const auto& [w, h] : std::vector<std::pair<int, int>>{{400, 400}, {640, 360}}) {
    const Camera camera = frame_camera(V, parse_view("iso"), static_cast<double>(w) / h, Projection::Orthographic);
    RenderOptions options;
    options.width = w;
    options.height = h;
    const Image image = render_scene(scene, camera, options);
    double coverage = 0;
    for (size_t i = 0; i < image.rgb.size(); i += 3) coverage += (255.0 - image.rgb[i]) / 255.0;
    const double pixels_per_unit = h / (2 * camera.half_height);
    const double expected = kPi * r * r * pixels_per_unit * pixels_per_unit;
    EXPECT_NEAR(coverage / expected, 1.0, 0.02) << w << "x" << h;
    // Framing: the sphere touches neither border.
    for (int x = 0; x < w; ++x) {
      EXPECT_EQ(pixel(image, x, 0)[0], 255);
      EXPECT_EQ(pixel(image, x, h - 1)[0], 255);
    }
  }
}

TEST(Render, PlaneFacingTheCameraShowsItsExactColor) {
  REQUIRE_RENDERER();
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  square(1, V, F);
  SurfaceLayer layer{V, F};
  layer.color = Eigen::Vector3f(0.2f, 0.6f, 0.9f);
  Scene scene;
  scene.layers.push_back(layer);
  RenderOptions options;
  options.width = options.height = 101;
  for (const char* view : {"front", "back"}) { // two-sided lighting: the back looks the same
    const Camera camera = frame_camera(V, parse_view(view), 1.0);
    const Image image = render_scene(scene, camera, options);
    expect_color(image, 50, 50, layer.color, 2, view);
    expect_color(image, 30, 70, layer.color, 2, view);
  }
}

TEST(Render, TiltedPlaneFollowsLambertWithAmbient) {
  REQUIRE_RENDERER();
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  square(1, V, F);
  SurfaceLayer layer{V, F};
  layer.color = Eigen::Vector3f(0.9f, 0.9f, 0.5f);
  Scene scene;
  scene.layers.push_back(layer);
  RenderOptions options;
  options.width = options.height = 101;
  for (double azimuth : {30.0, 60.0}) {
    const Camera camera = frame_camera(V, ViewDirection{azimuth, 0}, 1.0, Projection::Orthographic);
    const Image image = render_scene(scene, camera, options);
    // Orthographic headlight: the light makes the same angle with the plane everywhere.
    const float shade = options.ambient + options.diffuse * static_cast<float>(std::cos(azimuth * kPi / 180));
    expect_color(image, 50, 50, layer.color * shade, 2, "azimuth " + std::to_string(azimuth));
  }
}

TEST(Render, TranslucentLayerBlendsOverTheOpaqueOne) {
  REQUIRE_RENDERER();
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  square(1, V, F);
  SurfaceLayer base{V, F}, top{V, F};
  top.V.col(2).array() += 0.1;
  base.color = Eigen::Vector3f(0.1f, 0.2f, 0.9f);
  top.color = Eigen::Vector3f(0.9f, 0.9f, 0.1f);
  top.opacity = 0.25f;
  Scene scene;
  scene.layers = {top, base}; // order of layers must not matter
  RenderOptions options;
  options.width = options.height = 64;
  const Image image = render_scene(scene, frame_camera(scene_points(scene), parse_view("front"), 1.0), options);
  expect_color(image, 32, 32, 0.25f * top.color + 0.75f * base.color, 3, "blend");
}

TEST(Render, ClipPlaneCutsAway) {
  REQUIRE_RENDERER();
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  square(1, V, F);
  SurfaceLayer layer{V, F};
  layer.color = Eigen::Vector3f::Zero();
  Scene scene;
  scene.layers.push_back(layer);
  scene.clip_plane = Eigen::Vector4d(1, 0, 0, 0); // keep x >= 0
  RenderOptions options;
  options.width = options.height = 100;
  const Image image = render_scene(scene, frame_camera(V, parse_view("front"), 1.0, Projection::Orthographic), options);
  EXPECT_EQ(pixel(image, 25, 50)[0], 255); // x < 0: cut away, background
  EXPECT_EQ(pixel(image, 75, 50)[0], 0);
}

TEST(Render, BadInputsAreInputErrors) {
  Scene scene;
  SurfaceLayer layer;
  layer.V = Eigen::MatrixXd::Zero(3, 3);
  layer.F = Eigen::MatrixXi(1, 3);
  layer.F << 0, 1, 3;
  scene.layers.push_back(layer);
  Camera camera;
  camera.eye = Eigen::Vector3d(0, 0, 1);
  camera.target = Eigen::Vector3d::Zero();
  camera.up = Eigen::Vector3d(0, 1, 0);
  RenderOptions options;
  EXPECT_THROW(render_scene(scene, camera, options), InputError);
  scene.layers[0].F << 0, 1, 2;
  options.width = 0;
  EXPECT_THROW(render_scene(scene, camera, options), InputError);
  EXPECT_THROW(parse_view("sideways"), InputError);
  EXPECT_THROW(parse_view("10,95"), InputError);
  EXPECT_THROW(parse_view("10,"), InputError);
  EXPECT_THROW(frame_camera(Eigen::MatrixXd(0, 3), ViewDirection{}, 1.0), InputError);
  EXPECT_THROW(frame_camera(Eigen::MatrixXd::Zero(3, 3), ViewDirection{}, 0.0), InputError);
  EXPECT_THROW(Image(-1, 4), InputError);
  EXPECT_THROW(downsample(Image(5, 4), 2), InputError);
  EXPECT_THROW(encode_png(Image()), InputError);
}

TEST(Camera, ViewPresetsPointWhereTheySay) {
  const std::map<std::string, Eigen::Vector3d> expected{{"front", {0, 0, 1}}, {"back", {0, 0, -1}}, {"right", {1, 0, 0}},
                                                        {"left", {-1, 0, 0}}, {"top", {0, 1, 0}},  {"bottom", {0, -1, 0}}};
  for (const auto& [name, dir] : expected) EXPECT_LT((eye_direction(parse_view(name)) - dir).norm(), 1e-12) << name;
  const ViewDirection v = parse_view("45,-30");
  EXPECT_DOUBLE_EQ(v.azimuth_deg, 45);
  EXPECT_DOUBLE_EQ(v.elevation_deg, -30);
}

TEST(Camera, FramingKeepsEveryPointInsideTheViewport) {
  Eigen::MatrixXd points = Eigen::MatrixXd::Random(500, 3);
  points.col(0) *= 3; // elongated
  for (const char* view : {"iso", "top", "left", "20,70"})
    for (Projection projection : {Projection::Perspective, Projection::Orthographic})
      for (double aspect : {0.5, 1.0, 16.0 / 9}) {
        const Camera camera = frame_camera(points, parse_view(view), aspect, projection);
        const Eigen::Matrix4d pv = camera.projection_matrix(aspect) * camera.view_matrix();
        double widest = 0;
        for (Eigen::Index i = 0; i < points.rows(); ++i) {
          const Eigen::Vector4d clip = pv * Eigen::Vector4d(points(i, 0), points(i, 1), points(i, 2), 1);
          ASSERT_GT(clip.w(), 0);
          const Eigen::Vector3d ndc = clip.head<3>() / clip.w();
          EXPECT_LE(ndc.head<2>().cwiseAbs().maxCoeff(), 1.0) << view;
          EXPECT_LE(std::abs(ndc.z()), 1.0) << view; // inside near/far
          widest = std::max(widest, ndc.head<2>().cwiseAbs().maxCoeff());
        }
        EXPECT_GT(widest, 0.75) << view << " aspect " << aspect; // and not lost in the middle
      }
}

TEST(ColorMap, RampEndsAndMiddle) {
  ColorScale scale;
  scale.max = 0.2;
  EXPECT_LT((scale.color(0) - scale.ramp_color(0)).norm(), 1e-6);
  EXPECT_LT((scale.color(0.1) - scale.ramp_color(0.5)).norm(), 1e-6);
  EXPECT_LT((scale.color(5) - scale.ramp_color(1)).norm(), 1e-6); // clamped
  const Eigen::Vector3f green = scale.ramp_color(0), yellow = scale.ramp_color(0.5), red = scale.ramp_color(1);
  EXPECT_GT(green.y(), green.x());
  EXPECT_GT(red.x(), red.y());
  EXPECT_GT(yellow.x(), 0.8f);
  EXPECT_GT(yellow.y(), 0.8f);
}

TEST(ColorMap, NiceNumbersAndQuantiles) {
  EXPECT_DOUBLE_EQ(round_up_nice(0.013), 0.02);
  EXPECT_DOUBLE_EQ(round_up_nice(0.1), 0.1);
  EXPECT_DOUBLE_EQ(round_up_nice(0.23), 0.25);
  EXPECT_DOUBLE_EQ(round_up_nice(3.1), 5);
  EXPECT_DOUBLE_EQ(round_up_nice(0), 0);
  std::vector<double> v(101);
  for (int i = 0; i <= 100; ++i) v[i] = 100 - i;
  EXPECT_DOUBLE_EQ(quantile(v, 0.99), 99);
  EXPECT_DOUBLE_EQ(quantile(v, 0.5), 50);
  EXPECT_EQ(format_number(0.05), "0.05");
}

TEST(Figure, PanelColorMatchesTheColorBarAtItsValue) {
  REQUIRE_RENDERER();
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  square(1, V, F);
  ColorScale scale;
  scale.max = 0.1;
  std::vector<Panel> panels;
  for (double value : {0.01, 0.05, 0.08}) {
    SurfaceLayer layer{V, F};
    layer.face_colors = map_colors(scale, Eigen::VectorXd::Constant(2, value));
    Panel panel;
    panel.scene.layers.push_back(layer);
    panel.caption = "value " + format_number(value);
    panels.push_back(panel);
  }
  FigureOptions options;
  options.width = 900;
  options.height = 400;
  options.view = parse_view("front");
  options.color_bar = scale;
  FigureLayout layout;
  const Image image = render_figure(panels, options, &layout);
  ASSERT_EQ(layout.panels.size(), 3u);
  ASSERT_GT(layout.color_bar.w, 100);
  const double values[3] = {0.01, 0.05, 0.08};
  for (int i = 0; i < 3; ++i) {
    const PixelRect& p = layout.panels[i];
    const auto panel_rgb = pixel(image, p.x + p.w / 2, p.y + p.h / 2);
    const auto bar_rgb = pixel(image, layout.color_bar_column(values[i]), layout.color_bar.y + layout.color_bar.h / 2);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(panel_rgb[c], bar_rgb[c], 4) << "value " << values[i];
  }
  // The caption band holds dark text pixels.
  int dark = 0;
  for (int y = 0; y < layout.panels[0].y; ++y)
    for (int x = 0; x < layout.panels[0].w; ++x) dark += pixel(image, x, y)[0] < 128;
  EXPECT_GT(dark, 20);
}

TEST(Annotate, TextStaysInItsBox) {
  // Anti-aliased text: every pixel it touches (any coverage) lies in the box text_width x
  // text_height, including descenders, a glyph reaching left of its origin ('j') and non-ASCII.
  for (const std::string text : {"stretch 0.1", "jig qy", "\u03c3 \u2265 0.5 \u00c5"}) {
    Image image(260, 60);
    const int size = 20;
    draw_text(image, 10, 10, text, size, Rgb8{0, 0, 0});
    const int w = text_width(text, size), h = text_height(size);
    int inside = 0, outside = 0, solid = 0;
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x) {
        const int v = image.at(x, y)[0];
        const bool in_box = x >= 10 && x < 10 + w && y >= 10 && y < 10 + h;
        (in_box ? inside : outside) += v < 255;
        solid += v == 0;
      }
    EXPECT_GT(inside, 100) << text;
    EXPECT_GT(solid, 20) << text; // stems are fully covered, not only grey
    EXPECT_EQ(outside, 0) << text;
    EXPECT_GT(w, static_cast<int>(text.size()) * size / 5) << text;
  }
  EXPECT_LE(text_width(fit_text("a long caption that does not fit", 20, 100), 20), 100);
  EXPECT_EQ(fit_text("short", 20, 100), "short");
  EXPECT_GT(text_width("WWWW", 20), text_width("iiii", 20)); // proportional, not monospaced
}

TEST(Image, DownsampleAveragesAndPngHasItsSignature) {
  Image image(4, 2, 0, 0, 0);
  image.fill_rect(0, 0, 1, 1, 200, 100, 40);
  const Image small = downsample(image, 2);
  ASSERT_EQ(small.width, 2);
  ASSERT_EQ(small.height, 1);
  EXPECT_EQ(small.at(0, 0)[0], 50);
  EXPECT_EQ(small.at(0, 0)[1], 25);
  EXPECT_EQ(small.at(0, 0)[2], 10);
  EXPECT_EQ(small.at(1, 0)[0], 0);
  const std::string png = encode_png(small);
  ASSERT_GT(png.size(), 8u);
  EXPECT_EQ(png.substr(1, 3), "PNG");
}

TEST(ShellRender, FaceStretchIsTheVolumeWeightedMeanOfItsTets) {
  // One prism of 3 tets with volumes 1/6, 2/6 and 3/6.
  Eigen::MatrixXd X(4, 3);
  X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  Eigen::MatrixXd X2 = X, X3 = X;
  X2.row(3) *= 2;
  X3.row(3) *= 3;
  Eigen::MatrixXd all(12, 3);
  all << X, X2, X3;
  Eigen::MatrixXi T(3, 4);
  T << 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11;
  const Eigen::VectorXd stretch = Eigen::Vector3d(0.6, 0.0, 0.2);
  const Eigen::VectorXd face = face_stretch_from_tets(all, T, stretch);
  ASSERT_EQ(face.size(), 1);
  EXPECT_NEAR(face[0], (1 * 0.6 + 2 * 0.0 + 3 * 0.2) / 6, 1e-12);
}

TEST(ShellRender, FaceStretchRefusesTetsOutsideTheVertices) {
  Eigen::MatrixXd X(4, 3);
  X << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  Eigen::MatrixXi T(3, 4);
  T << 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 4; // id 4 of 4 vertices
  const Eigen::VectorXd stretch = Eigen::Vector3d::Zero();
  EXPECT_THROW(face_stretch_from_tets(X, T, stretch), InputError);
  T(2, 3) = -1;
  EXPECT_THROW(face_stretch_from_tets(X, T, stretch), InputError);
  T(2, 3) = 3;
  EXPECT_NO_THROW(face_stretch_from_tets(X, T, stretch));
}

namespace {

// A shell over the builtin plane (normal prisms of thickness eta) whose every position is then
// scaled by s: each tet is the ideal one scaled uniformly, so its stretch is 3 (s - 1)^2.
struct ScaledPlaneShell {
  TriMesh base;
  RestTets rest;
  Eigen::MatrixXd X; // 2n x 3, scaled
  double eta = 0.1;
};

ScaledPlaneShell scaled_plane_shell(double s) {
  ScaledPlaneShell shell;
  shell.base = make_plane(6);
  const int n = shell.base.num_vertices();
  shell.rest = prism_rest_tets(shell.base.F, n, normal_prisms(shell.base.V, shell.base.F, shell.eta));
  shell.X.resize(2 * n, 3);
  shell.X.topRows(n) = shell.base.V;
  shell.X.bottomRows(n) = shell.base.V;
  shell.X.bottomRows(n).col(2).array() += shell.eta;
  shell.X *= s;
  return shell;
}

// Writes DIR as `generate` does: base.obj, top.obj, shell.vtu (cell data stretch), report.json.
void write_shell_folder(const std::string& dir, const ScaledPlaneShell& shell, bool with_surfaces) {
  const int n = shell.base.num_vertices();
  if (with_surfaces) {
    TriMesh base = shell.base, top = shell.base;
    base.V = shell.X.topRows(n);
    top.V = shell.X.bottomRows(n);
    write_mesh(dir + "/base.obj", base);
    write_mesh(dir + "/top.obj", top);
  }
  TetMesh tets;
  tets.X = shell.X;
  tets.T = shell.rest.T;
  tets.cell_data.emplace_back("stretch", tet_stretch(shell.rest, shell.X));
  write_tet_mesh(dir + "/shell.vtu", tets);
  std::ofstream(dir + "/report.json") << nlohmann::json{{"method", "scaled"}, {"thickness", shell.eta}}.dump();
}

} // namespace

TEST(ShellRender, UniformlyScaledShellShowsTheColorBarValueOfItsStretch) {
  REQUIRE_RENDERER();
  for (double s : {1.05, 1.1, 1.15}) {
    const ScaledPlaneShell shell = scaled_plane_shell(s);
    const double expected = 3 * (s - 1) * (s - 1);
    RenderSubject subject;
    subject.name = "plane";
    const int n = shell.base.num_vertices();
    subject.shell.base = shell.X.topRows(n);
    subject.shell.top = shell.X.bottomRows(n);
    subject.shell.F = shell.base.F;
    subject.shell.thickness = shell.eta * s;
    subject.face_stretch = face_stretch_from_tets(shell.X, shell.rest.T, tet_stretch(shell.rest, shell.X));
    ASSERT_NEAR(subject.face_stretch.maxCoeff(), expected, 1e-9);
    ASSERT_NEAR(subject.face_stretch.minCoeff(), expected, 1e-9);

    ShellRenderOptions options;
    options.color_max = 0.1;
    options.figure.width = 480;
    options.figure.height = 400;
    options.figure.view = parse_view("front");
    FigureLayout layout;
    const Image image = render_subjects({subject}, {}, options, &layout);
    ASSERT_TRUE(layout.color_scale.has_value());
    const PixelRect& panel = layout.panels[0];
    const auto shown = pixel(image, panel.x + panel.w / 2, panel.y + panel.h / 2);
    const auto bar = pixel(image, layout.color_bar_column(expected), layout.color_bar.y + layout.color_bar.h / 2);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(shown[c], bar[c], 4) << "s = " << s << " channel " << c;
    // And it is the ramp's color for 3 (s - 1)^2 itself.
    expect_color(image, panel.x + panel.w / 2, panel.y + panel.h / 2, layout.color_scale->color(expected), 3, "ramp");
  }
}

TEST(ShellRender, ShellFolderLoadsWithStretchFromShellVtu) {
  const ScaledPlaneShell shell = scaled_plane_shell(1.1);
  test::TempDir dir("render-shell");
  write_shell_folder(dir.path().string(), shell, true);
  const RenderSubject subject = load_render_subject(dir.path().string());
  EXPECT_EQ(subject.method, "scaled");
  EXPECT_DOUBLE_EQ(subject.shell.thickness, shell.eta);
  ASSERT_EQ(subject.face_stretch.size(), shell.base.num_faces());
  EXPECT_NEAR(subject.face_stretch.mean(), 0.03, 1e-9);
  EXPECT_EQ(subject.shell.F, shell.base.F);
}

TEST(ShellRender, FacesAreRecoveredFromTetsWhenOnlyShellVtuIsThere) {
  const ScaledPlaneShell shell = scaled_plane_shell(1.0);
  test::TempDir dir("render-vtu");
  write_shell_folder(dir.path().string(), shell, false);
  const RenderSubject subject = load_render_subject(dir.path().string());
  ASSERT_EQ(subject.shell.F.rows(), shell.base.F.rows());
  for (Eigen::Index f = 0; f < shell.base.F.rows(); ++f) {
    const std::set<int> want{shell.base.F(f, 0), shell.base.F(f, 1), shell.base.F(f, 2)};
    const std::set<int> got{subject.shell.F(f, 0), subject.shell.F(f, 1), subject.shell.F(f, 2)};
    EXPECT_EQ(got, want) << "face " << f;
    // Same orientation: the normal points to the top (+z for the plane).
    const Eigen::Vector3d a = subject.shell.base.row(subject.shell.F(f, 0)), b = subject.shell.base.row(subject.shell.F(f, 1)),
                          c = subject.shell.base.row(subject.shell.F(f, 2));
    EXPECT_GT((b - a).cross(c - a).z(), 0) << "face " << f;
  }
  EXPECT_NEAR(subject.face_stretch.maxCoeff(), 0, 1e-12);
}

TEST(ShellRender, ThicknessRatioPerVertexIsTheReportsThickness) {
  // A plane's top 0.1 above it, with its centre vertex slid sideways to 0.01 above the plane: the
  // colour is the distance to the base over eta, as the report's thickness (the offset length
  // |top_i - base_i| showed the slid vertex 2.5 eta thick).
  const TriMesh plane = make_plane(2);
  Shell shell;
  shell.base = plane.V;
  shell.F = plane.F;
  shell.top = plane.V.rowwise() + Eigen::RowVector3d(0, 0, 0.1);
  const int centre = 4;
  ASSERT_TRUE(plane.V.row(centre).isZero());
  shell.top.row(centre) << 0.5, 0, 0.01;
  shell.thickness = 0.2;
  const Eigen::VectorXd t = vertex_thickness_ratio(shell);
  const ShellMetrics m = shell_metrics(shell.base, shell.F, shell.top, shell.thickness, false);
  for (int i = 0; i < 9; ++i) {
    EXPECT_NEAR(t[i], i == centre ? 0.05 : 0.5, 1e-12) << i;
    EXPECT_NEAR(t[i], m.vertex_thickness[i], 1e-12) << i;
  }
}

TEST(RenderCli, WritesAPngOfTheRequestedSize) {
  REQUIRE_RENDERER();
  test::TempDir dir("render-cli");
  const std::string png = dir.file("out.png");
  const auto r = test::run_cli("render builtin:sphere builtin:torus -o '" + png + "' --size 320x200 --view front --caption a --caption b -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Image image = read_png(png);
  EXPECT_EQ(image.width, 320);
  EXPECT_EQ(image.height, 200);
}

TEST(RenderCli, ShellFolderWithStretchColors) {
  REQUIRE_RENDERER();
  test::TempDir dir("render-cli-shell");
  const std::string shell_dir = dir.file("shell");
  std::filesystem::create_directories(shell_dir);
  write_shell_folder(shell_dir, scaled_plane_shell(1.1), true);
  const std::string png = dir.file("shell.png");
  const auto r = test::run_cli("render '" + shell_dir + "' -o '" + png + "' --size 400x300 --view front --max 0.1 -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Image image = read_png(png);
  ColorScale scale;
  scale.max = 0.1;
  // The centre of the image is inside the plane: the ramp color of 0.03.
  expect_color(image, 200, 150, scale.color(0.03), 3, "centre");
}

// A cut surface (a triangle soup) renders, and `gshell render` says it is cut, as generate does.
TEST(RenderCli, ACutSurfaceRendersWithTheInputsWarning) {
  REQUIRE_RENDERER();
  test::TempDir dir("render-cli-soup");
  const TriMesh sphere = make_sphere(1);
  write_mesh(dir.file("soup.obj"), test::triangle_soup(sphere));
  EXPECT_FALSE(load_render_subject(dir.file("soup.obj")).warnings.empty());
  EXPECT_TRUE(load_render_subject("builtin:sphere:1").warnings.empty());
  const std::string png = dir.file("soup.png");
  const auto r = test::run_cli("render '" + dir.file("soup.obj") + "' -o '" + png + "' --size 64x64 -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("gshell render: warning: " + dir.file("soup.obj") + ": vertices "), std::string::npos) << r.err;
  EXPECT_EQ(read_png(png).width, 64);
}

TEST(RenderCli, BadArgumentsFailCleanly) {
  test::TempDir dir("render-cli-bad");
  const std::string png = dir.file("out.png");
  EXPECT_EQ(test::run_cli("render builtin:sphere -o '" + png + "' --size 10x").exit_code, 1);
  EXPECT_EQ(test::run_cli("render builtin:sphere -o '" + png + "' --view sideways").exit_code, 1);
  EXPECT_EQ(test::run_cli("render builtin:sphere -o '" + png + "' --max 0").exit_code, 1);
  EXPECT_EQ(test::run_cli("render builtin:sphere -o '" + png + "' --max lots").exit_code, 1);
  EXPECT_EQ(test::run_cli("render builtin:sphere builtin:torus -o '" + png + "' --caption one").exit_code, 1);
  EXPECT_EQ(test::run_cli("render '" + dir.file("missing.obj") + "' -o '" + png + "'").exit_code, 1);
  EXPECT_EQ(test::run_cli("render builtin:sphere -o '" + png + "' --color stretch").exit_code, 1);
  EXPECT_EQ(test::run_cli("render '" + dir.path().string() + "' -o '" + png + "'").exit_code, 1); // not a shell folder
  EXPECT_EQ(test::run_cli("render builtin:sphere -o '" + dir.file("no/such/dir/x.png") + "'").exit_code, 1);
  EXPECT_EQ(test::count_entries(dir.path()), 0);
}

TEST(ShellRender, ScaleIsFixedByDefaultAndFollowsTheBestPanelWhenAutomatic) {
  REQUIRE_RENDERER();
  std::vector<RenderSubject> subjects(2);
  for (int i = 0; i < 2; ++i) {
    const ScaledPlaneShell shell = scaled_plane_shell(1.0);
    const int n = shell.base.num_vertices();
    subjects[i].name = "plane " + std::to_string(i);
    subjects[i].shell.base = shell.X.topRows(n);
    subjects[i].shell.top = shell.X.bottomRows(n);
    subjects[i].shell.F = shell.base.F;
    subjects[i].shell.thickness = shell.eta;
    // Face values 0 .. 0.3 (panel 0) and 0 .. 3 (panel 1): 99th percentiles ~0.3 and ~3.
    const Eigen::Index m = shell.base.F.rows();
    subjects[i].face_stretch = Eigen::VectorXd::LinSpaced(m, 0, i == 0 ? 0.3 : 3.0);
  }
  ShellRenderOptions options;
  options.figure.width = 320;
  options.figure.height = 160;
  FigureLayout layout;
  render_subjects(subjects, {}, options, &layout);
  ASSERT_TRUE(layout.color_scale.has_value());
  EXPECT_DOUBLE_EQ(layout.color_scale->max, kDefaultStretchMax);
  options.auto_max = true;
  render_subjects(subjects, {}, options, &layout);
  EXPECT_DOUBLE_EQ(layout.color_scale->max, 0.5); // 0.297 rounded up to a round number
  options.color_by = ColorBy::Thickness;
  render_subjects(subjects, {}, options, &layout);
  EXPECT_NEAR(layout.color_scale->min, 0.99, 1e-12); // |t - 1| = 0 everywhere: the minimum spread 0.01
  EXPECT_NEAR(layout.color_scale->max, 1.01, 1e-12);
}

TEST(RenderCli, GenerateWithRenderWritesAPreview) {
  REQUIRE_RENDERER();
  test::TempDir dir("render-preview");
  const std::string out = dir.file("torus");
  // A trailing slash names the same folder.
  const auto r = test::run_cli("generate builtin:torus:16 -o '" + out + "/' --thickness-ratio 0.05 --iterations 3 --render -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("preview.png"), std::string::npos);
  const Image preview = read_png(out + "/preview.png");
  EXPECT_EQ(preview.width, 1280);
  EXPECT_EQ(preview.height, 720);
}

TEST(ShellRender, PreviewOfADeformOutputShowsFirstMiddleAndLastFrame) {
  REQUIRE_RENDERER();
  // Five frames, frame k the plane shell scaled by s_k = 1 + 0.035 k: stretch 3 (s_k - 1)^2, a
  // different color for every frame (all below the default red end of 0.1). The preview must
  // show frames 1, 3 and 5, left to right, each in the ramp color of its own stretch.
  test::TempDir dir("render-preview-frames");
  constexpr int kFrames = 5;
  auto scale = [](int k) { return 1.0 + 0.035 * k; };
  for (int k = 1; k <= kFrames; ++k) {
    const std::string frame = dir.file("frame_000" + std::to_string(k));
    std::filesystem::create_directories(frame);
    write_shell_folder(frame, scaled_plane_shell(scale(k)), false);
  }
  // Seen head-on (the plane's normal is +z), a face shows exactly its color.
  const std::string png = render_shell_preview(dir.path().string(), {}, parse_view("front"));
  EXPECT_EQ(png, dir.file("preview.png"));
  const Image preview = read_png(png);
  ASSERT_EQ(preview.width, 1280);
  ASSERT_EQ(preview.height, 720);
  ColorScale colors;
  colors.max = kDefaultStretchMax;
  const int shown[3] = {1, 3, 5};
  const int panel_w = preview.width / 3;
  for (int i = 0; i < 3; ++i) {
    const int k = shown[i];
    const double stretch = 3 * (scale(k) - 1) * (scale(k) - 1);
    // The panels share one camera, so every plane is centred in its panel; the centre of the
    // image's height lies inside the panel area (between caption and color bar).
    expect_color(preview, i * panel_w + panel_w / 2, preview.height / 2, colors.color(stretch), 3,
                 "panel " + std::to_string(i) + " (frame " + std::to_string(k) + ")");
    // Neighbouring frames look different enough for a wrong frame to show.
    const double other = 3 * (scale(k == 1 ? 2 : k - 1) - 1) * (scale(k == 1 ? 2 : k - 1) - 1);
    EXPECT_GT((colors.color(stretch) - colors.color(other)).cwiseAbs().maxCoeff() * 255, 12) << "frame " << k;
    // Each panel has a caption (dark text in the band above its render).
    int dark = 0;
    for (int y = 0; y < preview.height / 12; ++y)
      for (int x = i * panel_w; x < (i + 1) * panel_w; ++x) dark += pixel(preview, x, y)[0] < 100;
    EXPECT_GT(dark, 20) << "caption of panel " << i;
  }
}
