// `gshell curvature MESH -o OUT.ply`: normal-cycle principal curvatures as PLY properties.
#include "command_registry.h"
#include "output_file.h"
#include "progress.h"
#include "surface_input.h"

#include <gshell/error.h>
#include <gshell/geometry/curvature.h>
#include <gshell/io/write_mesh.h>
#include <gshell/seconds_since.h>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

namespace gshell::cli {
namespace {

struct CurvatureArgs {
  std::string input, output;
  CurvatureOptions options;
  bool ascii = false;
};

double percentile(Eigen::VectorXd values, double p) {
  if (values.size() == 0) return 0;
  std::vector<double> v(values.data(), values.data() + values.size());
  const auto k = static_cast<std::ptrdiff_t>(std::clamp(p, 0.0, 1.0) * (v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

void add_curvature_scalars(std::vector<std::pair<std::string, Eigen::VectorXd>>& out,
                           const PrincipalCurvatures& c) {
  out.emplace_back("k1", c.k1);
  out.emplace_back("k2", c.k2);
  out.emplace_back("mean", c.mean());
  out.emplace_back("gauss", c.gaussian());
  const char* axes = "xyz";
  for (int i = 0; i < 3; ++i) out.emplace_back(std::string("e1") + axes[i], c.e1.col(i));
  for (int i = 0; i < 3; ++i) out.emplace_back(std::string("e2") + axes[i], c.e2.col(i));
}

void run_curvature(const CurvatureArgs& args) {
  check_output_file(args.output, ".ply", {args.input}); // PLY: it carries the curvature as properties
  const TriMesh mesh = cli::load_surface(args.input, "curvature");
  const auto start = std::chrono::steady_clock::now();
  const FaceCurvature faces = face_curvature(mesh.V, mesh.F, args.options);
  const VertexCurvature vertices = vertex_curvature(mesh.V, mesh.F, args.options);
  const double seconds = seconds_since(start);
  char line[128];
  std::snprintf(line, sizeof line, "%d faces, %d vertices in %.3f s", mesh.num_faces(), mesh.num_vertices(), seconds);
  Progress("curvature").line(line);

  MeshAttributes attributes;
  add_curvature_scalars(attributes.face_scalars, faces);
  add_curvature_scalars(attributes.vertex_scalars, vertices);
  write_mesh(args.output, mesh, attributes, args.ascii);

  const Eigen::VectorXd abs_k1 = faces.k1.cwiseAbs().cwiseMax(faces.k2.cwiseAbs());
  std::printf("%s: %d faces, %d vertices (face %d-ring, vertex %d-ring)\n", args.input.c_str(),
              mesh.num_faces(), mesh.num_vertices(), args.options.face_rings, args.options.vertex_rings);
  std::printf("  face k1     min %.6g  median %.6g  max %.6g\n", faces.k1.minCoeff(), percentile(faces.k1, 0.5),
              faces.k1.maxCoeff());
  std::printf("  face k2     min %.6g  median %.6g  max %.6g\n", faces.k2.minCoeff(), percentile(faces.k2, 0.5),
              faces.k2.maxCoeff());
  std::printf("  face max|k| median %.6g  p95 %.6g  max %.6g  (1/model units)\n", percentile(abs_k1, 0.5),
              percentile(abs_k1, 0.95), abs_k1.maxCoeff());
  std::printf("wrote %s (face and vertex properties k1 k2 mean gauss e1x e1y e1z e2x e2y e2z)\n",
              args.output.c_str());
}

void add_curvature_command(CLI::App& parent) {
  auto args = std::make_shared<CurvatureArgs>();
  CLI::App* cmd = parent.add_subcommand(
      "curvature",
      "Principal curvatures (normal-cycle tensor, Cohen-Steiner & Morvan 2003) per face and per vertex, "
      "written as PLY properties k1 >= k2, mean = (k1+k2)/2, gauss = k1*k2 and unit directions e1, e2. "
      "Signs: convex with the faces' outward normals is positive. Units: 1/model units.");
  cmd->add_option("mesh", args->input, "Input mesh file or builtin:NAME[:RES]")->required();
  cmd->add_option("-o,--output", args->output, "Output .ply file")->required();
  cmd->add_option("--face-rings", args->options.face_rings,
                  "Rings of triangles averaged per face (the paper's 2)")
      ->capture_default_str()
      ->check(CLI::Range(1, 16));
  cmd->add_option("--vertex-rings", args->options.vertex_rings, "Rings of triangles averaged per vertex")
      ->capture_default_str()
      ->check(CLI::Range(1, 16));
  cmd->add_flag("--ascii", args->ascii, "Write ASCII PLY instead of binary");
  cmd->callback([args] { run_curvature(*args); });
}

const CommandRegistrar reg{60, add_curvature_command};

} // namespace
} // namespace gshell::cli
