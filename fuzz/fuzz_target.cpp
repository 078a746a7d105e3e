// libFuzzer entry point, compiled once per line of targets.def with GSHELL_FUZZ_NAME="<name>":
// the line of that name is the body. The targets call the functions the CLI and the Python module
// call on the same bytes (the readers behind read_mesh/read_tet_mesh, then what load_mesh and
// `gshell info` do with a surface; parse_handles behind read_handles, then the targets `pose`
// asks for), and check the postconditions the rest of gshell relies on.
#include "../src/io/surface_readers.h"
#include "../src/io/tet_formats.h"

#include <gshell/deform/handles.h>
#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/geometry/mesh_topology.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/geometry/weld_vertices.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/view/view_protocol.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

namespace {

using namespace gshell;

const std::string kName = "fuzz-input";

/// A broken postcondition: reported like a crash, with the input saved by libFuzzer.
[[noreturn]] void violated(const char* what) {
  std::fprintf(stderr, "fuzz target postcondition violated: %s\n", what);
  std::abort();
}

/// A reader's result: indices in range, UVs consistent (read_mesh.h); then what `gshell info`
/// (mesh_stats, validate_mesh) and every command's load_mesh (require_valid_mesh) do with it, and
/// on a valid surface `convert --weld` (weld_boundary_vertices: every face corner where it was).
void check_surface(const TriMesh& mesh) {
  if (mesh.V.cols() != 3 || mesh.F.cols() != 3) violated("surface must be n x 3 and m x 3");
  if (mesh.F.size() > 0 && (mesh.F.minCoeff() < 0 || mesh.F.maxCoeff() >= mesh.V.rows()))
    violated("face index out of range");
  if (mesh.FUV.size() > 0) {
    if (mesh.FUV.rows() != mesh.F.rows() || mesh.UV.cols() != 2) violated("texture coordinates malformed");
    if (mesh.FUV.minCoeff() < 0 || mesh.FUV.maxCoeff() >= mesh.UV.rows()) violated("UV index out of range");
  }
  (void)mesh_stats(mesh);
  require_valid_mesh(mesh, kName);
  int merged = -1;
  const TriMesh welded = weld_boundary_vertices(mesh, &merged);
  if (merged < 0 || welded.V.rows() != mesh.V.rows() - merged || welded.F.rows() != mesh.F.rows())
    violated("weld: vertex or face count");
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (welded.F(f, k) < 0 || welded.F(f, k) >= welded.V.rows() || welded.V.row(welded.F(f, k)) != mesh.V.row(mesh.F(f, k)))
        violated("weld: a face corner moved");
}

/// An empty list for a reader's `skipped` names, so that the fuzzer runs that path too.
std::vector<std::string>* no_skipped_yet() {
  static std::vector<std::string> names;
  names.clear();
  return &names;
}

/// A tet reader's result: ids in range, one data row per point/cell.
void check_tets(const TetMesh& mesh) {
  if (mesh.X.cols() != 3 || mesh.T.cols() != 4) violated("tet mesh must be N x 3 and K x 4");
  if (mesh.T.size() > 0 && (mesh.T.minCoeff() < 0 || mesh.T.maxCoeff() >= mesh.X.rows()))
    violated("tet vertex id out of range");
  for (const auto& [name, data] : mesh.point_data)
    if (data.rows() != mesh.X.rows()) violated("point data rows != points");
  for (const auto& [name, data] : mesh.cell_data)
    if (data.rows() != mesh.T.rows()) violated("cell data rows != cells");
}

/// A small rest shell the handles are resolved against: the offset shell of an icosphere
/// (42 base vertices, shell ids 0..83, coordinates within [-1.1, 1.1]).
const Shell& rest_shell() {
  static const Shell shell = [] {
    const TriMesh sphere = make_builtin("builtin:sphere:1");
    Shell s;
    s.base = sphere.V;
    s.F = sphere.F;
    s.thickness = 0.1;
    s.top = offset_top(s.base, s.F, s.thickness);
    return s;
  }();
  return shell;
}

/// Accepted handles: disjoint, in-range vertex sets and finite targets along the whole motion.
void check_handles(const HandleSet& set) {
  const int num_vertices = 2 * rest_shell().num_base_vertices();
  const std::vector<int> ids = set.constrained_vertices();
  for (int v : ids)
    if (v < 0 || v >= num_vertices) violated("handle vertex out of range");
  const Eigen::MatrixXd X = rest_shell().vertices();
  for (const double t : {0.0, 0.5, 1.0}) {
    const Eigen::MatrixXd P = set.targets(X, t);
    if (P.rows() != static_cast<Eigen::Index>(ids.size())) violated("one target per handle vertex");
    if (!P.allFinite()) violated("handle targets are not finite");
  }
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  try {
#define GSHELL_FUZZ_TARGET(name, ...)                                                                           \
  if constexpr (std::string_view(#name) == GSHELL_FUZZ_NAME) {                                                 \
    __VA_ARGS__;                                                                                               \
  }
#include "targets.def"
#undef GSHELL_FUZZ_TARGET
  } catch (const InputError&) {
    // bad bytes, reported as such: the expected outcome
  }
  return 0;
}
