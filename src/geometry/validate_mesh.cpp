#include <gshell/geometry/validate_mesh.h>

#include <gshell/error.h>
#include <gshell/geometry/mesh_topology.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

namespace gshell {
namespace {

using Severity = MeshProblem::Severity;

/// Collects problems of one kind, listing the first few places and summarising the rest, so a
/// broken mesh with a million bad faces still gives a readable report.
class ProblemList {
public:
  static constexpr int kListed = 10;

  explicit ProblemList(std::vector<MeshProblem>& out) : out_(out) {}

  void add(Severity severity, const std::string& kind, std::string message) {
    int& seen = seen_[kind_index(kind, severity)].second;
    if (++seen <= kListed) out_.push_back({severity, std::move(message), 1});
  }

  /// Appends "N more <kind>" for every kind that went over the limit.
  void finish() {
    for (size_t i = 0; i < kinds_.size(); ++i) {
      const int rest = seen_[i].second - kListed;
      if (rest > 0)
        out_.push_back({seen_[i].first, "... and " + std::to_string(rest) + " more " + kinds_[i], rest});
    }
  }

private:
  size_t kind_index(const std::string& kind, Severity severity) {
    const auto it = std::find(kinds_.begin(), kinds_.end(), kind);
    if (it != kinds_.end()) return static_cast<size_t>(it - kinds_.begin());
    kinds_.push_back(kind);
    seen_.push_back({severity, 0});
    return kinds_.size() - 1;
  }

  std::vector<MeshProblem>& out_;
  std::vector<std::string> kinds_;
  std::vector<std::pair<Severity, int>> seen_;
};

template <class Faces>
std::string face_text(const Faces& F, int f) {
  return "face " + std::to_string(f) + " (" + std::to_string(F(f, 0)) + ", " + std::to_string(F(f, 1)) + ", " +
         std::to_string(F(f, 2)) + ")";
}

} // namespace

const char* severity_name(MeshProblem::Severity severity) {
  switch (severity) {
  case Severity::Error: return "error";
  case Severity::Warning: return "warning";
  default: return "info";
  }
}

std::vector<MeshProblem> validate_mesh(const TriMesh& mesh) {
  std::vector<MeshProblem> problems;
  const Eigen::MatrixXd& V = mesh.V;
  const Eigen::MatrixXi& F = mesh.F;
  if (V.rows() == 0 || F.rows() == 0) {
    problems.push_back({Severity::Error, V.rows() == 0 ? "mesh is empty (no vertices)" : "mesh has no faces", 1});
    return problems;
  }
  if (V.cols() != 3 || F.cols() != 3) {
    problems.push_back({Severity::Error, "mesh must have 3 coordinates per vertex and 3 vertices per face", 1});
    return problems;
  }
  const int n = static_cast<int>(V.rows()), m = static_cast<int>(F.rows());
  ProblemList list(problems);
  // Row-major copies: the checks below visit faces and vertices in random order, and one cache
  // line per face or vertex instead of three is most of the speed.
  const Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor> T = F;
  const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> P = V;

  std::vector<char> finite(n, 1);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = Eigen::Vector3d::Constant(-INFINITY);
  for (int v = 0; v < n; ++v) {
    const Eigen::Vector3d p = P.row(v).transpose();
    if (!p.allFinite()) {
      finite[v] = 0;
      list.add(Severity::Error, "vertices with non-finite coordinates",
               "vertex " + std::to_string(v) + " has a non-finite coordinate (NaN or infinity)");
      continue;
    }
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double diagonal = (hi - lo).allFinite() ? (hi - lo).norm() : 0.0;
  // Collinear points give a cross product of rounding size (~1e-16 diag^2); anything below this
  // is too small to carry a normal or a prism.
  const double min_double_area = 1e-12 * diagonal * diagonal;

  for (int f = 0; f < m; ++f) {
    bool indices_ok = true;
    for (int k = 0; k < 3; ++k) {
      if (T(f, k) < 0 || T(f, k) >= n) {
        indices_ok = false;
        list.add(Severity::Error, "faces with out-of-range indices",
                 face_text(T, f) + " has vertex index " + std::to_string(T(f, k)) + " out of range [0, " +
                     std::to_string(n) + ")");
        break;
      }
    }
    if (!indices_ok) continue;
    if (T(f, 0) == T(f, 1) || T(f, 1) == T(f, 2) || T(f, 2) == T(f, 0)) {
      list.add(Severity::Error, "faces with a repeated index", face_text(T, f) + " repeats a vertex index");
      continue;
    }
    if (!finite[T(f, 0)] || !finite[T(f, 1)] || !finite[T(f, 2)]) continue;
    const Eigen::Vector3d a = P.row(T(f, 0)), b = P.row(T(f, 1)), c = P.row(T(f, 2));
    if ((b - a).cross(c - a).norm() <= min_double_area)
      list.add(Severity::Error, "zero-area faces",
               face_text(T, f) + " has zero area (its vertices coincide or are collinear)");
  }

  const EdgeIncidence inc = edge_incidence(F, n);
  const auto corner_vertex = [&](int h) { return T(h / 3, h % 3); };
  std::vector<char> on_bad_edge(n, 0);
  for (int e = 0; e < inc.num_edges(); ++e) {
    const int a = inc.edges(e, 0), b = inc.edges(e, 1);
    const int* hs = inc.halfedges.data() + inc.offsets[e];
    const int valence = inc.valence(e);
    const auto edge_text = [&] { return "edge (" + std::to_string(a) + ", " + std::to_string(b) + ")"; };
    if (valence > 2) {
      std::string faces;
      for (int i = 0; i < std::min(valence, 6); ++i) faces += (i ? ", " : "") + std::to_string(hs[i] / 3);
      if (valence > 6) faces += ", ...";
      list.add(Severity::Error, "non-manifold edges",
               edge_text() + " is non-manifold: shared by " + std::to_string(valence) + " faces (" + faces + ")");
      on_bad_edge[a] = on_bad_edge[b] = 1;
    } else if (valence == 2) {
      const int f1 = hs[0] / 3, f2 = hs[1] / 3;
      if (corner_vertex(hs[0]) == corner_vertex(hs[1]))
        list.add(Severity::Error, "inconsistently oriented face pairs",
                 "faces " + std::to_string(f1) + " and " + std::to_string(f2) +
                     " are oriented inconsistently (both run along " + edge_text() + " in the same direction)");
    }
  }

  // Corners grouped by vertex (counting sort), then distinct fans per vertex via a stamp per root.
  std::vector<int> start(n + 1, 0);
  for (int f = 0; f < m; ++f)
    if (inc.face_used[f])
      for (int k = 0; k < 3; ++k) ++start[T(f, k) + 1];
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<int> corners(start.back());
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (int f = 0; f < m; ++f)
      if (inc.face_used[f])
        for (int k = 0; k < 3; ++k) corners[fill[T(f, k)]++] = 3 * f + k;
  }
  std::vector<char> referenced(n, 0);
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k)
      if (T(f, k) >= 0 && T(f, k) < n) referenced[T(f, k)] = 1;
  // Fans around a vertex: its corners, joined when they share a manifold edge (same neighbour
  // vertex, exactly two faces). Done per vertex on small local arrays, which is far more
  // cache-friendly than a global union-find over all corners.
  std::vector<std::pair<int, int>> around; // (neighbour vertex, local corner)
  std::vector<int> parent;
  for (int v = 0; v < n; ++v) {
    if (!referenced[v]) {
      list.add(Severity::Warning, "unreferenced vertices", "vertex " + std::to_string(v) + " is used by no face");
      continue;
    }
    if (on_bad_edge[v]) continue; // already reported through its non-manifold edge
    const int degree = start[v + 1] - start[v];
    around.clear();
    for (int i = 0; i < degree; ++i) {
      const int h = corners[start[v] + i], f = h / 3, k = h % 3;
      around.emplace_back(T(f, (k + 1) % 3), i);
      around.emplace_back(T(f, (k + 2) % 3), i);
    }
    std::sort(around.begin(), around.end());
    parent.resize(degree);
    std::iota(parent.begin(), parent.end(), 0);
    const auto root = [&](int x) {
      while (parent[x] != x) x = parent[x] = parent[parent[x]];
      return x;
    };
    int fans = degree;
    for (size_t i = 0; i + 1 < around.size(); ++i) {
      if (around[i].first != around[i + 1].first) continue;
      const int x = root(around[i].second), y = root(around[i + 1].second);
      if (x != y) {
        parent[x] = y;
        --fans;
      }
    }
    if (fans > 1)
      list.add(Severity::Error, "non-manifold vertices",
               "vertex " + std::to_string(v) + " is non-manifold: its faces form " + std::to_string(fans) +
                   " separate fans");
  }

  int boundary_edges = 0, first_boundary = -1;
  for (int e = 0; e < inc.num_edges(); ++e)
    if (inc.valence(e) == 1 && boundary_edges++ == 0) first_boundary = e;
  if (boundary_edges > 0) {
    const int loops = count_boundary_loops(inc, n);
    list.add(Severity::Info, "open boundaries",
             "open surface: " + std::to_string(loops) + " boundary loop" + (loops == 1 ? "" : "s") + ", " +
                 std::to_string(boundary_edges) + " boundary edges (e.g. edge (" +
                 std::to_string(inc.edges(first_boundary, 0)) + ", " + std::to_string(inc.edges(first_boundary, 1)) +
                 "))");
  }
  list.finish();
  std::stable_sort(problems.begin(), problems.end(),
                   [](const MeshProblem& x, const MeshProblem& y) { return x.severity > y.severity; });
  return problems;
}

void require_valid_mesh(const TriMesh& mesh, const std::string& name) {
  const auto problems = validate_mesh(mesh);
  const MeshProblem* first = nullptr;
  int more = 0;
  for (const auto& p : problems) {
    if (p.severity == Severity::Info) continue;
    if (!first && p.severity == Severity::Error)
      first = &p, more += p.count - 1;
    else
      more += p.count;
  }
  if (!first) return;
  std::string message = first->message;
  if (more > 0) message += " (and " + std::to_string(more) + " more problem" + (more == 1 ? "" : "s") + ")";
  throw InputError(with_file(name, message));
}

} // namespace gshell
