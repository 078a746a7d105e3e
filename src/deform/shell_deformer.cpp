#include <gshell/deform/shell_deformer.h>

#include <gshell/deform/base_frames.h>

#include "frame_guard.h"

#include <gshell/error.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/guard/extrusion_directions.h>
#include <gshell/seconds_since.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/quality/triangle_intersections.h>
#include <gshell/shell/generate_shell.h>
#include <gshell/shell/ideal_prisms.h>
#include <gshell/shell/prism_tets.h>

#include "guard/small_parts.h"

#include <Eigen/Geometry>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

#include <chrono>
#include <cmath>
#include <numeric>
#include <optional>
#include <string>

namespace gshell {

namespace {

using Clock = std::chrono::steady_clock;


// 6 x the signed volume of the tet with corners U (rows).
double six_volume(const TetCorners& U) {
  return (U.row(1) - U.row(0)).cross(U.row(2) - U.row(0)).dot(U.row(3) - U.row(0));
}

std::vector<int> base_ids(int n) {
  std::vector<int> ids(n);
  std::iota(ids.begin(), ids.end(), 0);
  return ids;
}

} // namespace

RestTets deformation_rest_tets(const Shell& shell, int* replaced) {
  check_shell(shell, "the rest shell", false); // a thickness of 0 is measured below
  const int n = shell.num_base_vertices();
  double eta = shell.thickness;
  if (!(eta > 0) && n > 0) eta = (shell.top - shell.base).rowwise().norm().mean();
  if (!std::isfinite(eta)) throw InputError("deformation_rest_tets: the shell's thickness is not finite");
  // Row-major copies: a tet reads whole points, at random places in millions of them.
  using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
  const Points base = shell.base;
  // Parts of the base too small for the thickness kept the valid start's thin layer in generation
  // (GuardOptions::small_part_ratio): their tets, however thin against eta, are their own proper
  // shapes. Replaced, a frame as still as the rest pushed such a part's top out to eta, into
  // itself, and every frame was a guarded one: CGAL's elephant beside a speck of radius 1e-4, 60 s
  // for the identity frame. Only a flat or inverted one of theirs is replaced.
  std::vector<char> on_small_part(n, 0);
  const double small_part_ratio = GuardOptions{}.small_part_ratio;
  if (small_part_ratio > 0)
    for (int v : detail::small_part_vertices(shell.base, shell.F, eta / small_part_ratio)) on_small_part[v] = 1;
  // The positions form: the rest shell's own tets need no matrix each (1.1 GB at 15.7M tets), only
  // the few replaced by their ideal shape. The ideal corners are normal_prisms's: a base vertex
  // itself, a top vertex eta along the unit normal of the tet's face above its base vertex.
  RestTets rest = rest_tets_in_positions_form(
      shell.vertices(), build_prism_tets(shell.F, n), [&](Eigen::Index t, const std::array<int, 4>& ids, TetCorners& U) {
        const Eigen::Index f = t / 3;
        const Eigen::RowVector3d a = base.row(shell.F(f, 0)), b = base.row(shell.F(f, 1)), c = base.row(shell.F(f, 2));
        const Eigen::RowVector3d lift = normal_prism_lift(a.transpose(), b.transpose(), c.transpose(), eta).transpose();
        TetCorners ideal;
        for (int k = 0; k < 4; ++k) {
          const int v = ids[k];
          ideal.row(k) = v < n ? base.row(v) : Eigen::RowVector3d(base.row(v - n) + lift);
        }
        const double volume = six_volume(U);
        const bool flat = on_small_part[shell.F(f, 0)] ? volume <= 0 : volume < kMinRestVolumeRatio * six_volume(ideal);
        if (!flat) return false;
        U = ideal;
        return true;
      });
  if (replaced) *replaced = static_cast<int>(rest.override_tets.size());
  return rest;
}

const char* warm_start_name(WarmStart w) {
  switch (w) {
  case WarmStart::PreviousTop: return "previous";
  case WarmStart::Translated: return "translated";
  case WarmStart::RotatedOffset: return "rotated";
  case WarmStart::Extrapolated: return "extrapolated";
  }
  return "?";
}

WarmStart parse_warm_start(const std::string& name) {
  if (name == "previous") return WarmStart::PreviousTop;
  if (name == "translated") return WarmStart::Translated;
  if (name == "rotated") return WarmStart::RotatedOffset;
  if (name == "extrapolated") return WarmStart::Extrapolated;
  throw InputError("unknown warm_start '" + name + "' (expected extrapolated, rotated, translated or previous)");
}

GuardOptions frame_guard_options() {
  // Generation's Hessians and local solve; its contact support (0.03) is not taken: a frame that
  // presses the top against itself (a plane folded shut) then lets one side bulge past the middle
  // of the gap while the other side thins for both, where 0.1 thins both sides alike. Where the
  // rest shell's parts lie closer than that, GuardOptions' contact_rest_fraction caps the support.
  const GuardOptions generation = generation_guard_options();
  GuardOptions o;
  o.projected_volume_hessian = generation.projected_volume_hessian;
  o.projected_contact_hessian = generation.projected_contact_hessian;
  o.local_rings = generation.local_rings;
  // A drag's last sub-step ends in local/global iterations creeping to the tolerance, with or
  // without barriers acting (a pose of bunny00: 1,675 of its 2,088 guarded iterations; CGAL's lion:
  // 1,577 of 2,368, 24 pairs active; docs/valid-deformation.md).
  o.anderson_history = 5;
  // A frame or pose step the guard refuses is mostly right: its few wrong spots mended in place
  // cost a fraction of a drag from the last frame or pose to the same minimum
  // (docs/valid-deformation.md, "Mending a refused step" and "Mending a refused frame").
  o.mend_rings = 10;
  // A frame's barriers act on a few spots (tens to hundreds of vertices), where CG spent ten and
  // more solves with the whole shell's factor per direction (a pose of CGAL's refined_elephant:
  // 0.35-0.45 s per guarded iteration, 82 % of the run in those solves; 50 s instead of over 25
  // minutes with the exact directions, docs/valid-deformation.md).
  o.exact_direction_vertices = 256;
  // Where the model holds a soft mode for stiff, the iterations creep along it (a pose of CGAL's
  // turbine, twisted by 45 degrees in two steps: 3,365 guarded iterations and 158 s in step 2);
  // with steps lengthened up to 64x, 556 iterations and 31 s, to the same tolerance
  // (docs/valid-deformation.md, "Lengthened steps").
  o.max_step_multiple = 64;
  return o;
}

void DeformOptions::check() const {
  if (!(tolerance >= 0) || !std::isfinite(tolerance)) throw InputError("tolerance must be >= 0");
  if (max_iterations < 0)
    throw InputError("iterations must be >= 0 (got " + std::to_string(max_iterations) + "; 0 keeps the start)");
  if (!(substep_edge_change > 0 && substep_edge_change <= 2))
    throw InputError("substep_edge_change must be in (0, 2]");
  if (max_substeps < 1) throw InputError("max_substeps must be >= 1");
  if (!(substep_tolerance > 0 && substep_tolerance < 1)) throw InputError("substep_tolerance must be in (0, 1)");
  check_guard_options(guard);
}

const char* frame_method_name(FrameMethod m) {
  switch (m) {
  case FrameMethod::Unguarded: return "unguarded";
  case FrameMethod::Bounded: return "bounded";
  case FrameMethod::Guarded: return "guarded";
  case FrameMethod::Mended: return "mended";
  case FrameMethod::TetsOnly: return "tets_only";
  case FrameMethod::Regenerated: return "regenerated";
  case FrameMethod::Failed: return "failed";
  }
  return "?";
}

int count_thinned_vertices(const Eigen::MatrixXd& base, const Eigen::MatrixXd& top, const Eigen::MatrixXd& rest_base,
                           const Eigen::MatrixXd& rest_top) {
  for (const Eigen::MatrixXd* m : {&top, &rest_base, &rest_top})
    if (m->rows() != base.rows() || m->cols() != base.cols())
      throw InputError("count_thinned_vertices: base, top, rest base and rest top must have one shape (got " +
                       std::to_string(m->rows()) + " x " + std::to_string(m->cols()) + " beside " +
                       std::to_string(base.rows()) + " x " + std::to_string(base.cols()) + ")");
  int count = 0;
  for (Eigen::Index i = 0; i < base.rows(); ++i)
    count += (top.row(i) - base.row(i)).norm() < kThinnedFraction * (rest_top.row(i) - rest_base.row(i)).norm();
  return count;
}

VertexRings vertex_rings(const Eigen::MatrixXi& F, int n) {
  // Compressed from the start (both directions of every face edge, counted, placed, then sorted
  // and made unique per vertex in parallel): a vector per vertex cost an allocation each.
  if (n < 0) throw InputError("vertex_rings: negative vertex count");
  if (F.size() > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= n))
    throw InputError("vertex_rings: a face refers to a vertex outside 0.." + std::to_string(n - 1));
  VertexRings out;
  std::vector<int> start(n + 1, 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) start[F(f, c) + 1] += 2;
  for (int i = 0; i < n; ++i) start[i + 1] += start[i];
  std::vector<int> ids(start[n]), fill(start.begin(), start.end() - 1);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = F(f, c), b = F(f, (c + 1) % 3);
      ids[fill[a]++] = b;
      ids[fill[b]++] = a;
    }
  std::vector<int> unique_count(n);
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 4096), [&](const tbb::blocked_range<int>& range) {
    for (int i = range.begin(); i != range.end(); ++i) {
      const auto first = ids.begin() + start[i], last = ids.begin() + start[i + 1];
      std::sort(first, last);
      unique_count[i] = static_cast<int>(std::unique(first, last) - first);
    }
  });
  out.start.assign(n + 1, 0);
  for (int i = 0; i < n; ++i) out.start[i + 1] = out.start[i] + unique_count[i];
  out.ids.resize(out.start[n]);
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 4096), [&](const tbb::blocked_range<int>& range) {
    for (int i = range.begin(); i != range.end(); ++i)
      std::copy_n(ids.begin() + start[i], unique_count[i], out.ids.begin() + out.start[i]);
  });
  return out;
}

namespace {

// Maximises tr(R^T C) over rotations by Newton steps on the rotation vector: for B = C R^T the
// gradient is g = axial(B - B^T) and the Hessian tr(B) I - sym(B), positive definite near the
// optimum; where it is not (far from it), the step of Mueller et al. 2016 ("A robust method to
// extract the rotational part of deformations"), g / |tr B|, is taken instead. Started from the
// identity, the small frame-to-frame rotations of an animation take 2-3 steps.
Eigen::Matrix3d fit_rotation(const Eigen::Matrix3d& C) {
  const double norm = C.norm();
  if (!(norm > 0) || !std::isfinite(norm)) return Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d A = C / norm;
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  for (int iteration = 0; iteration < 30; ++iteration) {
    const Eigen::Matrix3d B = A * R.transpose();
    const Eigen::Vector3d g(B(2, 1) - B(1, 2), B(0, 2) - B(2, 0), B(1, 0) - B(0, 1));
    const double trace = B.trace();
    const Eigen::Matrix3d H = trace * Eigen::Matrix3d::Identity() - 0.5 * (B + B.transpose());
    // Positive definite (Sylvester) -> Newton step by the adjugate, else the robust step.
    const double m1 = H(0, 0), m2 = H(0, 0) * H(1, 1) - H(0, 1) * H(1, 0), det = H.determinant();
    const Eigen::Vector3d w = m1 > 0 && m2 > 0 && det > 1e-12 ? Eigen::Vector3d(H.inverse() * g)
                                                             : Eigen::Vector3d(g / (std::abs(trace) + 1e-9));
    const double angle = w.norm();
    // Capped so a step never overshoots; the quaternion form needs no trigonometry.
    const Eigen::Vector3d v = angle > 1.0 ? Eigen::Vector3d(w / angle) : w;
    q = Eigen::Quaterniond(1.0, 0.5 * v.x(), 0.5 * v.y(), 0.5 * v.z()) * q;
    q.normalize();
    R = q.toRotationMatrix();
    // Newton converges quadratically: after a step below 1e-4 rad the error is ~1e-8 rad, which
    // moves an offset of length eta by 1e-8 eta: plenty for a warm start.
    if (angle < 1e-4) break;
  }
  return R;
}

} // namespace

std::vector<Eigen::Matrix3d> ring_rotations(const Eigen::MatrixXd& old_base, const Eigen::MatrixXd& new_base,
                                            const Eigen::MatrixXd& old_normals, const Eigen::MatrixXd& new_normals,
                                            const VertexRings& rings) {
  const int n = static_cast<int>(old_base.rows());
  std::vector<Eigen::Matrix3d> rotations(n);
  // Row-major copies: each ring visit reads one contiguous point instead of three strided values.
  using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
  const Points P = old_base, Q = new_base;
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 1024), [&](const tbb::blocked_range<int>& range) {
    for (int i = range.begin(); i != range.end(); ++i) {
      Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
      double squared_lengths = 0;
      const Eigen::Vector3d p = P.row(i).transpose(), q = Q.row(i).transpose();
      for (int k = rings.start[i]; k < rings.start[i + 1]; ++k) {
        const int j = rings.ids[k];
        const Eigen::Vector3d dp = P.row(j).transpose() - p, dq = Q.row(j).transpose() - q;
        C.noalias() += dq * dp.transpose();
        squared_lengths += dp.squaredNorm();
      }
      // A regular ring contributes about (sum |dp|^2 / 2) per in-plane direction: weighting the
      // normal alike makes C nearly isotropic, and the fit converges in a few steps.
      C.noalias() += 0.5 * squared_lengths * new_normals.row(i).transpose() * old_normals.row(i);
      rotations[i] = fit_rotation(C);
    }
  });
  return rotations;
}

namespace {

Eigen::MatrixXd rotate_offsets(const Eigen::MatrixXd& old_base, const Eigen::MatrixXd& old_top,
                               const Eigen::MatrixXd& new_base, const std::vector<Eigen::Matrix3d>& rotations) {
  const int n = static_cast<int>(old_base.rows());
  Eigen::MatrixXd top(n, 3);
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 4096), [&](const tbb::blocked_range<int>& range) {
    for (int i = range.begin(); i != range.end(); ++i)
      top.row(i) = new_base.row(i) + (rotations[i] * (old_top.row(i) - old_base.row(i)).transpose()).transpose();
  });
  return top;
}

} // namespace

Eigen::MatrixXd rotated_offset_top(const Eigen::MatrixXd& old_base, const Eigen::MatrixXd& old_top,
                                   const Eigen::MatrixXd& new_base, const Eigen::MatrixXi& F,
                                   const VertexRings& rings,
                                   std::vector<Eigen::Matrix3d>* rotations) {
  std::vector<Eigen::Matrix3d> R =
      ring_rotations(old_base, new_base, vertex_normals(old_base, F), vertex_normals(new_base, F), rings);
  Eigen::MatrixXd top = rotate_offsets(old_base, old_top, new_base, R);
  if (rotations) *rotations = std::move(R);
  return top;
}

ShellDeformer::ShellDeformer(const Shell& rest)
    : rest_((check_shell(rest, "the rest shell"), rest)), // every frame is checked against its thickness
      solver_(deformation_rest_tets(rest, &replaced_), 2 * rest.num_base_vertices(), base_ids(rest.num_base_vertices())),
      current_(rest.vertices()),
      rings_(vertex_rings(rest.F, rest.num_base_vertices())),
      current_normals_(vertex_normals(rest.base, rest.F)) {}

ShellDeformer::~ShellDeformer() = default;
ShellDeformer::ShellDeformer(ShellDeformer&&) noexcept = default;
ShellDeformer& ShellDeformer::operator=(ShellDeformer&&) noexcept = default;

void ShellDeformer::reset() {
  current_ = rest_.vertices();
  current_clean_ = true;
  resume_.resize(0, 3);
  current_normals_ = vertex_normals(rest_.base, rest_.F);
  last_correction_.resize(0, 3);
  last_motion_ = 0;
}

FrameResult ShellDeformer::solve(const Eigen::MatrixXd& new_base, const DeformOptions& options) {
  const int n = rest_.num_base_vertices();
  if (new_base.cols() != 3)
    throw InputError("the new base has " + std::to_string(new_base.cols()) + " coordinates per vertex, not 3");
  if (new_base.rows() != n)
    throw InputError("the new base has " + std::to_string(new_base.rows()) + " vertices, the shell's base has " +
                     std::to_string(n));
  require_frame_for_shell(new_base, rest_, "the new base");
  options.check();

  const auto start = Clock::now();
  const Eigen::MatrixXd old_base = current_.topRows(n), old_top = current_.bottomRows(n);
  Eigen::MatrixXd X(2 * n, 3);
  X.topRows(n) = new_base;
  const double motion = (new_base - old_base).norm();
  Eigen::MatrixXd rotated; // the RotatedOffset start, to measure the solver's correction
  std::vector<Eigen::Matrix3d> rotations;
  Eigen::MatrixXd new_normals = vertex_normals(new_base, rest_.F);
  switch (options.warm_start) {
  case WarmStart::PreviousTop: X.bottomRows(n) = old_top; break;
  case WarmStart::Translated: X.bottomRows(n) = old_top + (new_base - old_base); break;
  case WarmStart::RotatedOffset:
  case WarmStart::Extrapolated:
    rotations = ring_rotations(old_base, new_base, current_normals_, new_normals, rings_);
    rotated = rotate_offsets(old_base, old_top, new_base, rotations);
    X.bottomRows(n) = rotated;
    if (options.warm_start == WarmStart::Extrapolated && last_correction_.rows() == n && last_motion_ > 0) {
      const double scale = std::min(1.0, motion / last_motion_);
      tbb::parallel_for(0, n, [&](int i) {
        X.row(n + i) += scale * (rotations[i] * last_correction_.row(i).transpose()).transpose();
      });
    }
    break;
  }
  const double warm_start_seconds = seconds_since(start);
  SolveOptions solve_options;
  solve_options.max_iterations = options.max_iterations;
  solve_options.tolerance = options.tolerance;
  solve_options.progress = options.progress;
  if (options.stage) options.stage("paper");
  const SolveResult solved = solver_.solve(X, solve_options);

  FrameResult result;
  result.warm_start_seconds = warm_start_seconds;
  result.iterations = solved.iterations;
  result.energy = solved.energy;
  result.converged = solved.converged;
  if (!options.allow_invalid) guard_frame(current_, X, options, result);
  result.seconds = seconds_since(start) - result.guard_setup_seconds;
  if (options.measure_stretch) {
    const auto stretch_start = Clock::now();
    result.stretch = stretch_stats(solver_.rest(), X);
    result.stretch_seconds = seconds_since(stretch_start);
  }
  result.thinned_vertices = count_thinned_vertices(X.topRows(n), X.bottomRows(n), rest_.base, rest_.top);
  if (options.certify) {
    const auto certify_start = Clock::now();
    if (result.certified) { // by the guard's acceptance, all but the base's own crossings
      result.certificate.base_self_intersections =
          static_cast<int>(surface_self_intersections(X.topRows(n), rest_.F).size());
    } else {
      result.certificate = guard_ ? guard_->certify(X) : certify_shell(X.topRows(n), X.bottomRows(n), rest_.F);
    }
    result.certificate_seconds = seconds_since(certify_start);
    result.valid = result.certificate.valid();
    if (!result.valid) {
      result.unextrudable_vertices = extrusion_directions(X.topRows(n), rest_.F).unextrudable;
      result.zero_area_faces = static_cast<int>(zero_area_faces(new_base, rest_.F).size());
      result.rest_faults_only = guard_ && !options.allow_invalid && result.method != FrameMethod::Failed &&
                                guard_->only_rest_faults(result.certificate);
    }
    // A certified frame is free of contacts whatever made it: the next frame may guard them again.
    if (!options.allow_invalid && result.valid) {
      current_clean_ = true;
      resume_.resize(0, 3);
    }
  }
  result.top = X.bottomRows(n);
  if (rotated.rows() == n) last_correction_ = result.top - rotated;
  else last_correction_.resize(0, 3);
  last_motion_ = motion;
  current_ = std::move(X);
  current_normals_ = std::move(new_normals);
  return result;
}

namespace {

// Whether certificate a finds fewer faults than b: fewer inverted tets, or as many and fewer
// intersecting pairs of the top (the base's own crossings are the same for both).
bool fewer_faults(const ShellCertificate& a, const ShellCertificate& b) {
  const auto pairs = [](const ShellCertificate& c) {
    return c.top_self_intersections + c.top_base_intersections + c.wall_intersections + c.nested_parts;
  };
  return a.inverted_tets < b.inverted_tets || (a.inverted_tets == b.inverted_tets && pairs(a) < pairs(b));
}

} // namespace

ShellCertificate ShellDeformer::regenerate(const Eigen::MatrixXd& X, Eigen::MatrixXd& Y, const DeformOptions& options,
                                           bool& start_gave_up) {
  const int n = rest_.num_base_vertices();
  SolveOptions paper;
  paper.max_iterations = options.max_iterations;
  paper.progress = options.progress;
  if (options.stage)
    paper.stage = [&options](const char* name) { options.stage(("regenerate " + std::string(name)).c_str()); };
  // From the frame's own solve rather than the offset: on CGAL's bull (frame 3 of a twist) the
  // fresh top's stretch came out 0.0042 instead of 0.0048, before the polish in guard_frame.
  const GuardedShell fresh = guarded_shell(X.topRows(n), rest_.F, solver_.rest(), rest_.thickness,
                                           generation_guard_options(), paper, {}, X.bottomRows(n));
  Y.resize(2 * n, 3);
  Y << X.topRows(n), fresh.top;
  start_gave_up = !fresh.start.inverted_tets.empty() || !fresh.start.intersections.empty();
  return guard_->certify(Y);
}

namespace {

// A frame whose base crosses itself at more pairs of faces than this many per face has no valid
// shell and next to nothing a guard could keep clean: squashed flat (bunny00 4.5 pairs per face,
// the elephant 4.6), collapsed onto a line (a plane, 52). A fold through itself stays well below
// (a plane bent by 240 degrees: 0.15), and there the guard still keeps every tet positive.
constexpr double kHopelessCrossingsPerFace = 1;

// Where the next guarded frame starts: from this one when it is clean, else from the last clean
// frame (`last`, where this one started, or the one kept from before it). A frame the guard made
// valid is clean only while the guard's choice of what to leave out is the rest shell's
// (clean_on_rest_terms): one made with more left out (the tets at vertices its base makes
// unextrudable, the triangles around its base's crossings) may keep faults there, which the next
// frame, starting from it, would leave out again and keep for good (one frame whose base crossed
// itself left an inverted tet in every later frame of CGAL's homer bent by 120 degrees, their bases
// clean). The certificate may still find such a frame valid (ShellDeformer::deform).
void carry_forward(bool clean, const Eigen::MatrixXd& last, bool& current_clean, Eigen::MatrixXd& resume) {
  current_clean = clean;
  if (clean) resume.resize(0, 3);
  else if (resume.rows() == 0) resume = last;
}

bool clean_on_rest_terms(const FrameGuard& guard) { return !guard.leaves_out_beyond_rest(); }

} // namespace

void ShellDeformer::take_mended(Eigen::MatrixXd& X, FrameMend& mended, int iterations, FrameResult& result) {
  X = std::move(mended.X);
  result.method = FrameMethod::Mended;
  result.valid = true;
  result.substeps = 0;
  result.guarded_iterations = iterations;
  result.certificate = std::move(mended.certificate);
  result.certified = true;
  result.energy.push_back(mended.energy);
  carry_forward(clean_on_rest_terms(*guard_), current_, current_clean_, resume_); // current_: where it started
}

void ShellDeformer::guard_frame(const Eigen::MatrixXd& last, Eigen::MatrixXd& X, const DeformOptions& options,
                                FrameResult& result) {
  // Building the guard (the first frame: a minute at 2.6M vertices) and testing the frame are
  // seconds on large shells.
  if (!guard_ || !guard_->built_with(options.guard)) {
    if (options.stage) options.stage("guard setup");
    const auto setup_start = Clock::now();
    guard_ = std::make_unique<FrameGuard>(rest_, std::make_shared<const RestTets>(solver_.rest()), options.guard, base_ids(rest_.num_base_vertices()),
                                          false);
    result.guard_setup_seconds = seconds_since(setup_start);
  }
  if (options.stage) options.stage("guard");
  // After a frame the guard could not make valid, the next one starts from the last valid frame
  // instead (an invalid shell carried forward would leave every later frame guarded by its tets
  // alone, or, after a Failed frame, not at all). Starting from where the contact guard gave up
  // was tried: from there (the tops pressed together) the drag stalls again where a drag from
  // the last valid frame completes (tests/deform_guard_test.cpp).
  const bool resumed = !current_clean_ && resume_.rows() == last.rows();
  const Eigen::MatrixXd& previous = resumed ? resume_ : last;
  result.resumed = resumed;
  const bool contacts = guard_->guards_contacts() && (current_clean_ || resumed);
  // A frame after one that left out more than the rest shell's choice (below) guards again every
  // tet positive at its start and every triangle away from its start's base crossings.
  if (resumed || guard_->leaves_out_beyond_rest()) guard_->leave_out(previous);
  ShellCertificate certificate;
  if (guard_->accepts(previous, X, contacts, &certificate)) {
    result.method = FrameMethod::Bounded;
    result.valid = true;
    if (certificate.intersections_tested()) {
      result.certificate = std::move(certificate);
      result.certified = true;
    }
    carry_forward(clean_on_rest_terms(*guard_), last, current_clean_, resume_);
    return;
  }
  // The mend, the drag and their retries found nothing on such a base, in minutes: CGAL's bunny00
  // squashed flat for one frame ran past 3 minutes, a 441-vertex plane collapsed onto a line 14 s.
  // The frame is the paper's solve, reported not valid (its base crossings named), and the next
  // frame starts from the last valid one.
  const int n = rest_.num_base_vertices();
  if (static_cast<double>(surface_self_intersections(X.topRows(n), rest_.F).size()) >
      kHopelessCrossingsPerFace * static_cast<double>(rest_.F.rows())) {
    result.method = FrameMethod::Failed;
    result.valid = false;
    carry_forward(false, last, current_clean_, resume_);
    return;
  }
  GuardedSolveOptions solve;
  solve.max_iterations = options.max_iterations;
  solve.tolerance = options.tolerance;
  solve.progress = options.progress;
  // A refused frame is mostly the paper's minimum with a few wrong spots. Where the drag from the
  // previous frame would take several sub-steps, those spots are first mended in place, as a
  // refused pose step's are (docs/valid-deformation.md, "Mending a refused frame"); a one-step
  // drag from a frame that close costs less than building the mend's solver. The mend's tops,
  // pulled in to a valid start, creep back out: solved to the frame's tolerance they stop short of
  // the drag's minimum (CGAL's dino bent by 30 degrees a frame: +6 % energy); to a tenth of it,
  // with the iterations the drag's sub-steps would have had, within 0.5 % of it on the models
  // measured, in a seventh to two thirds of the drag's time.
  // Where a mend ends well above the paper's energy it may have settled in another minimum than
  // the drag would (GuardOptions::mend_max_rise): it is kept aside, the drag runs, and the valid
  // frame of lower energy is returned.
  const int substeps = guard_->substeps_between(previous, X, options);
  FrameMend mended; // a valid mend kept aside while the drag runs (X empty: none)
  if (contacts && options.guard.mend_rings >= 0 && substeps > 1) {
    GuardedSolveOptions mend = solve;
    mend.tolerance = 0.1 * options.tolerance;
    mend.max_iterations = substeps * options.max_iterations;
    if (options.stage) options.stage("mend");
    mended = guard_->weighed_mend(X, options.guard.mend_rings, options.guard.mend_max_rise, mend, &certificate,
                                  [this](const Eigen::MatrixXd& Y) { return solver_.energy(Y); });
    if (mended.within_rise) {
      take_mended(X, mended, mended.iterations, result);
      return;
    }
  }
  Eigen::MatrixXd Y = previous;
  // The straight path from the previous frame is not the only way to a valid frame: a sliver face
  // (CGAL's triceratops has two) turns its normal by 90 degrees under a base motion far smaller
  // than the shell, the top over it must swing across to keep its tets positive, and the drag,
  // whose steps may each cost a tet 90% of its volume while an energy step restores about half,
  // stalls. A top made afresh over the new base, as guarded generation makes one (valid start,
  // then the barriers) towards the same rest shapes, does not have to follow that path. It is
  // tried as soon as the drag first stalls: on shells whose rest has many boundary pairs inside
  // the contact support (lion-head's) every stalled drag iteration costs a few hundred ms, and
  // the retries and the tets-only drag that followed took 10-50 s a frame where the regeneration
  // and its polish take a few.
  // It is kept on the terms a dragged frame is: only what the guard leaves out may be wrong (the
  // tets at an unextrudable vertex, the triangles around the base's crossings; CGAL's bull has
  // both). A base that crosses itself is the caller's, as in the drag's acceptance; the frame's
  // certificate still counts it.
  // When the fresh top is not clean, the guard leaves out what the new base itself breaks (the
  // tets of the prisms at the vertices it makes unextrudable, the triangles around its crossings
  // with itself) and the drag goes on: guarding them can hold it still (CGAL's anchor, frame 8 of
  // a twist: 84 inverted tets after a failed drag, 6 with them left out). Not before: such a
  // vertex forces an inversion only in a thin enough layer, and a frame made with its tets guarded
  // may have none (the anchor's frame 7; the sliver of tests/deform_guard_test.cpp). If the drag
  // still fails, the fresh top is taken when it is clean on the new terms.
  Eigen::MatrixXd fresh;
  ShellCertificate fresh_certificate;
  bool left_out = false, regeneration_tried = false, fresh_returned = false, start_gave_up = false;
  const auto regenerated = [&] {
    if (!regeneration_tried) fresh_certificate = regenerate(X, fresh, options, start_gave_up);
    regeneration_tried = true;
    return guard_->only_unguarded_faults(fresh_certificate);
  };
  const auto other_way = [&] {
    if (!regeneration_tried && regenerated()) return true;
    if (!left_out) guard_->leave_out(Y, &X);
    left_out = true;
    return false;
  };
  FrameGuard::Outcome outcome =
      guard_->drag(Y, X, substeps, contacts, true, solve, options.substep_tolerance, other_way, options.stage);
  // A drag that ends invalid takes the fresh top if it is clean on the terms now in effect (made at
  // the first stall, or here when the drag failed before any stall).
  if (!outcome.superseded && (outcome.method == FrameMethod::Failed || outcome.method == FrameMethod::TetsOnly) &&
      regenerated())
    outcome.superseded = true;
  if (outcome.superseded) {
    outcome.method = FrameMethod::Regenerated;
    Y = std::move(fresh);
    // Made with generation's barriers, the fresh frame is then brought to a minimum of the energy
    // the dragged frames minimise (the guarded solver from there, the base held): the frames of
    // one sequence differ by the base's motion, not by how each was made. On CGAL's bull (twist,
    // curvature 0.05 shell) the regenerated frames 4 and 5 then have the dragged frames' stretch to
    // the digits printed (0.0098 and 0.0174, against 0.0137 and 0.0231 without).
    const auto polish = [&options](const char*) {
      if (options.stage) options.stage("polish");
    };
    outcome.iterations +=
        guard_->drag(Y, X, 1, contacts, false, solve, options.substep_tolerance, {}, polish).iterations;
  } else if ((outcome.method == FrameMethod::Failed || outcome.method == FrameMethod::TetsOnly) &&
             guard_->only_unguarded_faults(fresh_certificate, /*near_left_out=*/true)) {
    // Invalid either way (the fresh top, made by the test above, was not clean on the frame's
    // terms), the fresh top is returned where it is clean on guarded generation's terms (its
    // faults at most a vertex away from what is left out): the tets-only drag guards no pair,
    // and its faults spread (a plane folded through itself by 200 degrees in one frame:
    // top/base and wall pairs 12 rings, 1.7 eta, from the crossings; the fresh top's all within
    // one ring). Not carried forward: its method stays tets_only or failed.
    Y = std::move(fresh);
    fresh_returned = true;
  } else if (outcome.method == FrameMethod::Failed && guard_->accepts(previous, X, false, nullptr)) {
    // Not even the tets could follow the drag: the paper's solve is still taken as tets-only when
    // the straight path to it keeps every guarded tet positive (it then inverts none of them).
    outcome.method = FrameMethod::TetsOnly;
    Y = X;
  } else if (outcome.method == FrameMethod::Failed && fewer_faults(fresh_certificate, guard_->certify(X))) {
    // Nothing valid: the fresh top (made above, not clean either) is returned where it has fewer
    // faults than the paper's solve (CGAL's turbine twisted by 90 degrees, frame 6, its base
    // crossing itself 22 times: 20 inverted tets and 105 intersecting pairs against 331 and 251).
    Y = std::move(fresh);
    fresh_returned = true;
  }
  const bool dragged_valid = outcome.method == FrameMethod::Guarded || outcome.method == FrameMethod::Regenerated;
  std::optional<double> dragged_energy; // evaluated once, where a mend kept aside needs it
  if (mended.X.rows() > 0 && dragged_valid) dragged_energy = solver_.energy(Y);
  if (mended.X.rows() > 0 && (!dragged_valid || *dragged_energy > mended.energy)) {
    take_mended(X, mended, mended.iterations + outcome.iterations, result);
    return;
  }
  result.method = outcome.method;
  result.fresh_top = outcome.method == FrameMethod::Regenerated || fresh_returned;
  result.substeps = outcome.substeps;
  result.guarded_iterations = mended.iterations + outcome.iterations; // a declined mend's too
  result.valid = dragged_valid;
  result.base_nearly_touching = !dragged_valid && start_gave_up;
  // The frame returned when not valid (tets only, or the paper's solve) is never carried forward.
  carry_forward(result.valid && clean_on_rest_terms(*guard_), last, current_clean_, resume_);
  if (outcome.method != FrameMethod::Failed || fresh_returned) { // else the paper's solve stands
    X = std::move(Y);
    result.energy.push_back(dragged_energy ? *dragged_energy : solver_.energy(X)); // the returned state's
  }
}

} // namespace gshell
