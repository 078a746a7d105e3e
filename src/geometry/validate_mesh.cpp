#include <gshell/geometry/validate_mesh.h>

#include <gshell/error.h>
#include <gshell/geometry/mesh_topology.h>
#include <gshell/geometry/weld_vertices.h>

#include <Eigen/Geometry>

#include "vertex_stars.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <string>

namespace gshell {
namespace {

using Severity = MeshProblem::Severity;

// Twice a face's area at most this times the squared bounding-box diagonal is zero: collinear
// points give a cross product of rounding size (~1e-16 diag^2), and anything below this is too
// small to carry a normal or a prism.
constexpr double kZeroDoubleArea = 1e-12;

/// Collects problems of one kind, listing the first few places and summarising the rest, so a
/// broken mesh with a million bad faces still gives a readable report.
class ProblemList {
public:
  static constexpr int kListed = 10;

  explicit ProblemList(std::vector<MeshProblem>& out) : out_(out) {}

  void add(Severity severity, const std::string& kind, std::string message) {
    int& seen = seen_[kind_index(kind, severity)].second;
    if (++seen <= kListed) out_.push_back({severity, std::move(message), 1, kind});
  }

  /// Appends "N more <kind>" for every kind that went over the limit.
  void finish() {
    for (size_t i = 0; i < kinds_.size(); ++i) {
      const int rest = seen_[i].second - kListed;
      if (rest > 0)
        out_.push_back({seen_[i].first, "... and " + std::to_string(rest) + " more " + kinds_[i], rest, kinds_[i]});
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

/// 3 significant digits, C's %g: "1e+200", "1.73e-150".
std::string short_number(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", x);
  return text;
}

std::string too_small_message(double diagonal) {
  return "the mesh is too small: its bounding box diagonal is " + short_number(diagonal) + "; gshell needs at least " +
         short_number(min_mesh_size) + " (areas and volumes would underflow; scale the mesh up)";
}

/// Why vertex v cannot be used (its row of V given), or "" when it can.
std::string coordinate_problem(const Eigen::Vector3d& p, int v) {
  if (!p.allFinite()) return "vertex " + std::to_string(v) + " has a non-finite coordinate (NaN or infinity)";
  if (std::string problem = too_large_coordinate(p); !problem.empty()) return "vertex " + std::to_string(v) + " has " + problem;
  return {};
}

/// Texture coordinates, when the mesh has any: two per row, one row of ids per face, ids in
/// range, finite values (a NaN one would make NaN texture-space tets in `gshell texture`).
void check_texture_coordinates(const TriMesh& mesh, ProblemList& list) {
  const Eigen::MatrixXd& UV = mesh.UV;
  const Eigen::MatrixXi& FUV = mesh.FUV;
  if (UV.rows() == 0 && FUV.rows() == 0) return;
  if (UV.cols() != 2 || FUV.cols() != 3 || FUV.rows() != mesh.F.rows()) {
    list.add(Severity::Error, "wrong texture coordinate shapes",
             "texture coordinates must be 2 per row with one row of 3 ids per face (got " + std::to_string(UV.rows()) +
                 " x " + std::to_string(UV.cols()) + " coordinates and " + std::to_string(FUV.rows()) + " x " +
                 std::to_string(FUV.cols()) + " ids for " + std::to_string(mesh.F.rows()) + " faces)");
    return;
  }
  for (Eigen::Index t = 0; t < UV.rows(); ++t)
    if (!UV.row(t).allFinite())
      list.add(Severity::Error, "non-finite texture coordinates",
               "texture coordinate " + std::to_string(t) + " is not finite (NaN or infinity)");
  const Eigen::Index k = UV.rows();
  for (Eigen::Index f = 0; f < FUV.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      if (FUV(f, c) < 0 || FUV(f, c) >= k) {
        list.add(Severity::Error, "texture ids out of range",
                 "face " + std::to_string(f) + " has texture coordinate id " + std::to_string(FUV(f, c)) +
                     " out of range [0, " + std::to_string(k) + ")");
        break;
      }
}

/// One line per kind of warning: its first entry and how many more there are.
std::vector<std::string> warnings_by_kind(const std::vector<MeshProblem>& problems, const std::string& name) {
  std::vector<std::string> kinds, lines;
  std::vector<int> more;
  for (const MeshProblem& p : problems) {
    if (p.severity != Severity::Warning) continue;
    const auto it = std::find(kinds.begin(), kinds.end(), p.kind);
    if (it == kinds.end()) {
      kinds.push_back(p.kind);
      lines.push_back(with_file(name, p.message));
      more.push_back(p.count - 1);
    } else {
      more[static_cast<std::size_t>(it - kinds.begin())] += p.count;
    }
  }
  for (std::size_t k = 0; k < lines.size(); ++k)
    if (more[k] > 0) lines[k] += " (and " + std::to_string(more[k]) + " more " + kinds[k] + ")";
  return lines;
}

/// The diagonal of the box of the vertices the faces use, those `counts(v)` accepts: the size a
/// face's area is measured against (a vertex no face uses, a stray pivot far away, is not the
/// surface's size). stableNorm: norm() squares first, and a diagonal of 1e-200 squared underflows.
template <class Points, class Faces, class Counts>
double face_box_diagonal(const Points& P, const Faces& T, Counts counts) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = Eigen::Vector3d::Constant(-INFINITY);
  for (Eigen::Index f = 0; f < T.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (const int v = T(f, k); counts(v)) {
        lo = lo.cwiseMin(P.row(v).transpose());
        hi = hi.cwiseMax(P.row(v).transpose());
      }
  return (hi - lo).allFinite() ? (hi - lo).stableNorm() : 0.0;
}

} // namespace

std::string too_large_coordinate(const Eigen::Vector3d& p) {
  const double magnitude = p.cwiseAbs().maxCoeff();
  if (!(magnitude >= max_coordinate_magnitude)) return {};
  return "a coordinate of magnitude " + short_number(magnitude) + "; gshell needs |x| < " +
         short_number(max_coordinate_magnitude) + " (volumes and products of lengths would overflow)";
}

const char* severity_name(MeshProblem::Severity severity) {
  switch (severity) {
  case Severity::Error: return "error";
  case Severity::Warning: return "warning";
  default: return "info";
  }
}

std::vector<int> zero_area_faces(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  if (F.rows() == 0) return {};
  if (V.cols() != 3 || F.cols() != 3) throw InputError("zero_area_faces: V and F need 3 columns");
  const Eigen::Index n = V.rows();
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k)
      if (F(f, k) < 0 || F(f, k) >= n)
        throw InputError("zero_area_faces: face " + std::to_string(f) + " has vertex index " +
                         std::to_string(F(f, k)) + " out of range [0, " + std::to_string(n) + ")");
  const double diagonal = face_box_diagonal(V, F, [](int) { return true; });
  const double min_double_area = kZeroDoubleArea * diagonal * diagonal;
  std::vector<int> out;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    if ((b - a).cross(c - a).norm() <= min_double_area) out.push_back(static_cast<int>(f));
  }
  return out;
}

std::vector<MeshProblem> validate_mesh(const TriMesh& mesh) {
  std::vector<MeshProblem> problems;
  const Eigen::MatrixXd& V = mesh.V;
  const Eigen::MatrixXi& F = mesh.F;
  if (V.rows() == 0 || F.rows() == 0) {
    problems.push_back({Severity::Error, V.rows() == 0 ? "mesh is empty (no vertices)" : "mesh has no faces", 1, "empty mesh"});
    return problems;
  }
  if (V.cols() != 3 || F.cols() != 3) {
    problems.push_back(
        {Severity::Error, "mesh must have 3 coordinates per vertex and 3 vertices per face", 1, "wrong matrix shapes"});
    return problems;
  }
  const int n = static_cast<int>(V.rows()), m = static_cast<int>(F.rows());
  ProblemList list(problems);
  // Row-major copies: the checks below visit faces and vertices in random order, and one cache
  // line per face or vertex instead of three is most of the speed.
  const detail::RowMajorFaces T = F;
  const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> P = V;

  // usable[v]: finite and within max_coordinate_magnitude. Faces at other vertices are not
  // measured: their areas would be NaN or overflow, and the vertex is already reported.
  std::vector<char> usable(n, 1);
  for (int v = 0; v < n; ++v) {
    const Eigen::Vector3d p = P.row(v).transpose();
    if (std::string problem = coordinate_problem(p, v); !problem.empty()) {
      usable[v] = 0;
      list.add(Severity::Error, p.allFinite() ? "vertices with too large coordinates" : "vertices with non-finite coordinates",
               std::move(problem));
    }
  }
  // Faces at out-of-range indices are reported below; a vertex no face uses is a warning there.
  const double diagonal = face_box_diagonal(P, T, [&](int v) { return v >= 0 && v < n && usable[v]; });
  // A mesh this small cannot be measured: areas and volumes underflow, and every face would be
  // reported as having zero area. (All vertices at one point is a different problem: zero area.)
  const bool too_small = diagonal > 0 && diagonal < min_mesh_size;
  if (too_small)
    list.add(Severity::Error, "too small mesh",
             too_small_message(diagonal));
  const double min_double_area = kZeroDoubleArea * diagonal * diagonal;

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
    if (too_small || !usable[T(f, 0)] || !usable[T(f, 1)] || !usable[T(f, 2)]) continue;
    const Eigen::Vector3d a = P.row(T(f, 0)), b = P.row(T(f, 1)), c = P.row(T(f, 2));
    if ((b - a).cross(c - a).norm() <= min_double_area)
      list.add(Severity::Error, "zero-area faces",
               face_text(T, f) + " has zero area (its vertices coincide or are collinear)");
  }

  check_texture_coordinates(mesh, list);

  // Everything topological is checked per vertex on its star (see vertex_stars.h). Edge (v, w)
  // with v < w is checked at v: the corners of v that have w as a neighbour are its faces.
  const detail::VertexStars stars(T, n);
  const std::vector<char> referenced = used_vertices(F, n);

  std::vector<detail::Neighbour> around;
  detail::DisjointSets fan_sets;
  std::vector<std::pair<int, int>> boundary; // boundary edges (v < w)
  for (int v = 0; v < n; ++v) {
    if (!referenced[v]) {
      list.add(Severity::Warning, "unreferenced vertices", "vertex " + std::to_string(v) + " is used by no face");
      continue;
    }
    const int degree = stars.degree(v);
    stars.neighbours(v, around);
    // Fans: corners joined through manifold edges (exactly two faces).
    fan_sets.reset(degree);
    int fans = degree;
    bool on_bad_edge = false;
    for (size_t i = 0; i < around.size();) {
      size_t j = i + 1;
      while (j < around.size() && around[j].vertex == around[i].vertex) ++j;
      const int w = around[i].vertex, valence = static_cast<int>(j - i);
      const auto edge_text = [&] { return "edge (" + std::to_string(std::min(v, w)) + ", " + std::to_string(std::max(v, w)) + ")"; };
      // Two faces on one edge with the same third vertex are one triangle twice. Said so, not as
      // the non-manifold edge or orientation clash it also makes (or, in opposite orientations,
      // as a valid closed surface enclosing nothing). Reported once, at its vertices v < w < third.
      bool duplicated = false;
      for (std::size_t q = i; q < j && q < i + 16; ++q)
        for (std::size_t r = q + 1; r < j && r < i + 16; ++r)
          if (around[q].third == around[r].third) {
            duplicated = true;
            const int u = around[q].third;
            if (v < w && w < u)
              list.add(Severity::Error, "duplicated faces",
                       "faces " + std::to_string(around[q].face) + " and " + std::to_string(around[r].face) +
                           " use the same three vertices (" + std::to_string(v) + ", " + std::to_string(w) + ", " +
                           std::to_string(u) + "): a face is duplicated");
          }
      if (duplicated) {
        on_bad_edge = true;
        if (valence == 2 && fan_sets.unite(around[i].corner, around[i + 1].corner)) --fans;
      } else if (valence > 2) {
        on_bad_edge = true;
        if (v < w) {
          std::string faces;
          for (int q = 0; q < std::min(valence, 6); ++q) faces += (q ? ", " : "") + std::to_string(around[i + q].face);
          if (valence > 6) faces += ", ...";
          list.add(Severity::Error, "non-manifold edges",
                   edge_text() + " is non-manifold: shared by " + std::to_string(valence) + " faces (" + faces + ")");
        }
      } else if (valence == 2) {
        if (fan_sets.unite(around[i].corner, around[i + 1].corner)) --fans;
        if (v < w && around[i].outgoing == around[i + 1].outgoing)
          list.add(Severity::Error, "inconsistently oriented face pairs",
                   "faces " + std::to_string(around[i].face) + " and " + std::to_string(around[i + 1].face) +
                       " are oriented inconsistently (both run along " + edge_text() + " in the same direction)");
      } else if (v < w) {
        boundary.emplace_back(v, w);
      }
      i = j;
    }
    if (fans > 1 && !on_bad_edge) // a vertex on a non-manifold edge is reported through the edge
      list.add(Severity::Error, "non-manifold vertices",
               "vertex " + std::to_string(v) + " is non-manifold: its faces form " + std::to_string(fans) +
                   " separate fans");
  }

  if (!boundary.empty()) {
    // A cut: boundary vertices on both sides of it at one position. Closed meshes have no boundary
    // and skip this (two closed parts touching at a point are the certificate's base crossings).
    std::vector<int> ends;
    ends.reserve(2 * boundary.size());
    for (const auto& [a, b] : boundary)
      for (int v : {a, b})
        if (usable[v]) ends.push_back(v);
    std::sort(ends.begin(), ends.end());
    ends.erase(std::unique(ends.begin(), ends.end()), ends.end());
    for (const auto& [kept, other] : coincident_vertices(V, std::move(ends)))
      list.add(Severity::Warning, "coincident boundary vertices",
               "vertices " + std::to_string(kept) + " and " + std::to_string(other) +
                   " are at the same position but not joined: the surface is cut there (a triangle soup or split "
                   "seams; the shell gets walls along the cut; `gshell convert --weld` joins them)");

    // Loops = connected pieces of the boundary-edge graph.
    detail::DisjointSets pieces(n);
    std::vector<char> seen(n, 0);
    int loops = 0;
    for (const auto& [a, b] : boundary) {
      loops += !seen[a] + !seen[b];
      seen[a] = seen[b] = 1;
      if (pieces.unite(a, b)) --loops;
    }
    list.add(Severity::Info, "open boundaries",
             "open surface: " + std::to_string(loops) + " boundary loop" + (loops == 1 ? "" : "s") + ", " +
                 std::to_string(boundary.size()) + " boundary edges (e.g. edge (" + std::to_string(boundary[0].first) +
                 ", " + std::to_string(boundary[0].second) + "))");
  }
  list.finish();
  std::stable_sort(problems.begin(), problems.end(),
                   [](const MeshProblem& x, const MeshProblem& y) { return x.severity > y.severity; });
  return problems;
}

std::vector<std::string> require_valid_mesh(const TriMesh& mesh, const std::string& name) {
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
  if (!first) return warnings_by_kind(problems, name);
  std::string message = first->message;
  if (more > 0) message += " (and " + std::to_string(more) + " more problem" + (more == 1 ? "" : "s") + ")";
  throw InputError(with_file(name, message));
}

void require_usable_coordinates(const Eigen::MatrixXd& V, const std::string& name) {
  if (V.cols() != 3) throw InputError(with_file(name, "positions must have 3 coordinates per vertex"));
  for (Eigen::Index v = 0; v < V.rows(); ++v)
    if (const std::string problem = coordinate_problem(V.row(v).transpose(), static_cast<int>(v)); !problem.empty())
      throw InputError(with_file(name, problem));
}

void require_usable_texture_coordinates(const TriMesh& mesh, const std::string& name) {
  std::vector<MeshProblem> problems;
  ProblemList list(problems);
  check_texture_coordinates(mesh, list);
  if (!problems.empty()) throw InputError(with_file(name, problems.front().message));
}

void require_usable_frame(const Eigen::MatrixXd& V, const std::string& name) {
  require_usable_coordinates(V, name);
  if (V.rows() == 0) return;
  // stableNorm, as validate_mesh: a diagonal of 1e-200 squared underflows to 0.
  const double diagonal = (V.colwise().maxCoeff() - V.colwise().minCoeff()).stableNorm();
  if (diagonal == 0) throw InputError(with_file(name, "every vertex is at one point"));
  if (diagonal < min_mesh_size)
    throw InputError(with_file(name, too_small_message(diagonal)));
}

} // namespace gshell
