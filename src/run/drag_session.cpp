#include <gshell/run/drag_session.h>

#include <gshell/deform/shell_deformer.h>
#include <gshell/error.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/quality/shell_certificate.h>
#include <gshell/quality/stretch.h>
#include <gshell/run/shell_folder.h>
#include <gshell/run/staged_folder.h>
#include <gshell/shell/prism_tets.h>
#include <gshell/solver/rest_tets.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>

namespace gshell {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

// What decides the solver: a new one is built only when this changes.
struct SolverKey {
  std::vector<int> vertices;
  ConstraintMode mode = ConstraintMode::Hard;
  double weight = 0;
  bool operator==(const SolverKey&) const = default;
};

SolverKey key_of(const HandleSet& h) {
  return {h.constrained_vertices(), h.mode, h.mode == ConstraintMode::Soft ? h.weight : 0.0};
}

Eigen::Vector3d rest_centroid(const Eigen::MatrixXd& rest_vertices, const std::vector<int>& vertices) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int v : vertices) c += rest_vertices.row(v).transpose();
  return vertices.empty() ? c : Eigen::Vector3d(c / static_cast<double>(vertices.size()));
}

// Everything an undo restores.
struct State {
  Eigen::MatrixXd X;
  HandleSet handles;
  double fraction = 0;         ///< of the last event
  Eigen::MatrixXd targets;     ///< of the last event; rows of handles.constrained_vertices()
  int motion_version = 0;      ///< bumped whenever a motion changes
  int version_of_last = 0;     ///< motion_version at the last event
  std::vector<PoseStepReport> steps;
};

// The event before the last one, to continue the drag's motion (not kept by undo points).
struct Before {
  bool valid = false;
  Eigen::MatrixXd X, targets;
  double fraction = 0;
  int version = 0;
};

} // namespace

struct DragSession::Impl {
  Shell rest;
  Eigen::MatrixXd rest_vertices;
  TriMesh surface;
  PoseOptions options;
  std::string shell_name, handles_name;
  State state;
  Before before;
  std::deque<State> undo;
  int undo_depth = kUndoDepth;
  std::unique_ptr<PoseSolver> solver;
  SolverKey solver_key;
  int builds = 0;
  SolveOptions last_limits;
  mutable std::optional<RestTets> rest_tets; ///< for result() before any solver exists
  /// The last valid state while drag() steps are unguarded previews (guard_drag_steps off).
  std::optional<Eigen::MatrixXd> valid_before_preview;
  /// preview() has anchored the solver's reduced level at the current state (cleared by
  /// everything else that moves the shell or changes the solver).
  bool preview_anchored = false;

  bool guarded() const { return !options.allow_invalid; }
  bool guarded_drags() const { return guarded() && options.guard_drag_steps; }

  const RestTets& tets() const {
    if (solver) return solver->rest_tets();
    if (!rest_tets)
      rest_tets = deformation_rest_tets(rest); // the solver's, which it stands in for
    return *rest_tets;
  }

  // Where the constrained vertices are now: the targets the next event moves away from.
  Eigen::MatrixXd current_rows(const HandleSet& h) const {
    const std::vector<int> ids = h.constrained_vertices();
    Eigen::MatrixXd P(static_cast<Eigen::Index>(ids.size()), 3);
    for (size_t r = 0; r < ids.size(); ++r) P.row(static_cast<Eigen::Index>(r)) = state.X.row(ids[r]);
    return P;
  }

  void replace_handles(HandleSet h) {
    check_handles(h, static_cast<int>(rest_vertices.rows()));
    preview_anchored = false;
    const bool same_vertices = key_of(h) == key_of(state.handles);
    state.handles = std::move(h);
    ++state.motion_version;
    if (!same_vertices) { // the last targets describe other vertices: no continuation across this
      before.valid = false;
      state.targets = current_rows(state.handles);
      state.version_of_last = state.motion_version;
    } else if (state.fraction == 0) {
      // At fraction 0 every motion gives the last targets (the rest rows): the last event belongs
      // to the new motions too, so the next drag continues along them as from a fresh session.
      state.version_of_last = state.motion_version;
    }
  }

  void ensure_solver() {
    const SolverKey key = key_of(state.handles);
    if (solver && key == solver_key) return;
    preview_anchored = false;
    solver.reset(); // free the old factorisations before building new ones
    try {
      solver = std::make_unique<PoseSolver>(rest, state.handles, options.solver, options.hierarchy);
    } catch (const InputError& e) {
      // What PoseSolver refuses is the handles on this shell (none, or a part left free): name their file.
      if (handles_name.empty()) throw;
      throw InputError(handles_name + ": " + e.what());
    }
    solver_key = key;
    ++builds;
  }

  // The last recorded step was made by solve_valid: its guard fields.
  PoseStepReport mark_guarded(const ValidStep& v) {
    PoseStepReport& step = state.steps.back();
    step.guarded = true;
    step.record_certificate(v.certificate); // its `valid` is v.valid
    step.blocked_by_contact = v.blocked_by_contact;
    step.method = v.method;
    step.guarded_iterations = v.guarded_iterations;
    step.drag_start = v.drag_start;
    step.guard_setup_seconds = v.guard_setup_seconds;
    step.rest_faults_only = v.rest_faults_only;
    return step;
  }

  PoseStepReport record(double fraction, const SolveResult& r, double seconds) {
    PoseStepReport step;
    step.fraction = fraction;
    step.iterations = r.iterations;
    step.energy = r.energy.empty() ? 0 : r.energy.back();
    step.seconds = seconds;
    step.converged = r.converged;
    state.steps.push_back(step);
    return step;
  }
};

DragSession::DragSession(Shell rest, const PoseOptions& options, TriMesh surface) : impl_(std::make_unique<Impl>()) {
  options.check();
  if (rest.F.rows() == 0 || rest.base.rows() != rest.top.rows()) throw InputError("drag session: the rest shell has no faces");
  if (!(rest.thickness > 0)) throw InputError("drag session: the rest shell needs a positive thickness");
  Impl& s = *impl_;
  s.rest_vertices = rest.vertices();
  if (surface.F.rows() == 0) surface.F = rest.F;
  surface.V = rest.base;
  s.surface = std::move(surface);
  s.rest = std::move(rest);
  s.options = options;
  s.last_limits = options.solve;
  s.state.X = s.rest_vertices;
}

DragSession::~DragSession() = default;
DragSession::DragSession(DragSession&&) noexcept = default;
DragSession& DragSession::operator=(DragSession&&) noexcept = default;

void DragSession::set_names(std::string shell, std::string handles) {
  impl_->shell_name = std::move(shell);
  impl_->handles_name = std::move(handles);
}

const HandleSet& DragSession::handles() const { return impl_->state.handles; }

void DragSession::set_handles(HandleSet handles) {
  checkpoint();
  impl_->replace_handles(std::move(handles));
}

int DragSession::add_handle(Handle handle, bool center_from_rest) {
  std::sort(handle.vertices.begin(), handle.vertices.end());
  handle.vertices.erase(std::unique(handle.vertices.begin(), handle.vertices.end()), handle.vertices.end());
  HandleSet h = impl_->state.handles;
  if (center_from_rest) {
    check_handles(HandleSet{{handle}}, static_cast<int>(impl_->rest_vertices.rows())); // ids first
    handle.center = rest_centroid(impl_->rest_vertices, handle.vertices);
  }
  h.handles.push_back(std::move(handle));
  set_handles(std::move(h));
  return static_cast<int>(impl_->state.handles.handles.size()) - 1;
}

void DragSession::remove_handle(int k) {
  HandleSet h = impl_->state.handles;
  if (k < 0 || k >= static_cast<int>(h.handles.size())) throw InputError("no handle " + std::to_string(k));
  h.handles.erase(h.handles.begin() + k);
  set_handles(std::move(h));
}

void DragSession::set_handle_vertices(int k, std::vector<int> vertices) {
  HandleSet h = impl_->state.handles;
  if (k < 0 || k >= static_cast<int>(h.handles.size())) throw InputError("no handle " + std::to_string(k));
  std::sort(vertices.begin(), vertices.end());
  vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
  Handle& handle = h.handles[k];
  handle.vertices = std::move(vertices);
  check_handles(h, static_cast<int>(impl_->rest_vertices.rows()));
  handle.center = rest_centroid(impl_->rest_vertices, handle.vertices);
  set_handles(std::move(h));
}

void DragSession::set_motion(int k, const Eigen::Vector3d& translate, const Eigen::Vector3d& axis, double degrees) {
  State& st = impl_->state;
  if (k < 0 || k >= static_cast<int>(st.handles.handles.size())) throw InputError("no handle " + std::to_string(k));
  if (!translate.allFinite() || !axis.allFinite() || !std::isfinite(degrees))
    throw InputError("handle " + std::to_string(k) + ": a motion number is not finite");
  if (const std::string problem = too_large_coordinate(translate); !problem.empty())
    throw InputError("handle " + std::to_string(k) + ": translate: " + problem);
  // stableNorm, as parse_handles: norm() squares first, which over- or underflows for extreme axes.
  const double length = axis.stableNorm();
  if (!(length > 0)) throw InputError("handle " + std::to_string(k) + ": the rotation axis is zero");
  Handle& h = st.handles.handles[k];
  h.translate = translate;
  h.axis = axis / length;
  h.degrees = degrees;
  ++st.motion_version;
}

PoseStepReport DragSession::drag(double fraction, const std::optional<SolveOptions>& options) {
  Impl& s = *impl_;
  if (!std::isfinite(fraction)) throw InputError("fraction must be finite");
  s.ensure_solver();
  s.preview_anchored = false;
  const auto start = Clock::now();
  State& st = s.state;
  const Eigen::MatrixXd P = st.handles.targets(s.rest_vertices, fraction);
  Eigen::MatrixXd next = st.X;
  if (s.options.extrapolate && s.before.valid) {
    double step = 0; // how far the new targets lie along the last change of targets
    if (s.before.version == st.version_of_last && st.version_of_last == st.motion_version) {
      // Along the handles' own motion: exact for the equal steps of `pose --steps`.
      if (st.fraction != s.before.fraction) step = (fraction - st.fraction) / (st.fraction - s.before.fraction);
    } else {
      const Eigen::MatrixXd last = st.targets - s.before.targets;
      const double length = last.squaredNorm();
      if (length > 0) step = (P - st.targets).cwiseProduct(last).sum() / length;
    }
    next = s.solver->predict_start(s.before.X, st.X, step, P);
  }
  const Eigen::MatrixXd from = s.guarded_drags() ? st.X : Eigen::MatrixXd();
  if (s.guarded() && !s.guarded_drags() && !s.valid_before_preview) s.valid_before_preview = st.X;
  s.before = Before{true, std::move(st.X), st.targets, st.fraction, st.version_of_last};
  st.X = std::move(next);
  const double predict_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  const SolveOptions limits = options.value_or(s.options.solve);
  s.last_limits = limits;
  if (s.guarded_drags()) {
    ValidStep valid;
    const SolveResult r = s.solver->solve_valid(from, st.X, P, limits, s.options.guard, &valid);
    st.targets = P;
    st.fraction = fraction;
    st.version_of_last = st.motion_version;
    // The guard's work (mend, drag, certificate) is the step's; building the guard is setup.
    s.record(fraction, r, std::chrono::duration<double>(Clock::now() - start).count() - valid.guard_setup_seconds);
    return s.mark_guarded(valid);
  }
  const SolveResult r = s.solver->solve(st.X, P, limits);
  st.targets = P;
  st.fraction = fraction;
  st.version_of_last = st.motion_version;
  PoseStepReport step = s.record(fraction, r, r.seconds + predict_seconds);
  if (!s.guarded()) { // as deform certifies its unguarded frames: the report says what each step is
    const Eigen::Index n = st.X.rows() / 2;
    step.record_certificate(certify_shell(st.X.topRows(n), st.X.bottomRows(n), s.rest.F));
    st.steps.back() = step; // what result() and write() report
  }
  return step;
}

PoseStepReport DragSession::preview(double fraction, int iterations) {
  Impl& s = *impl_;
  if (!std::isfinite(fraction)) throw InputError("fraction must be finite");
  if (iterations < 1) throw InputError("preview: iterations must be >= 1");
  s.ensure_solver();
  HierarchicalSolver* hierarchy = s.solver->hierarchical();
  if (!hierarchy || hierarchy->num_levels() < 2 || s.guarded_drags()) {
    SolveOptions limits = s.options.solve;
    limits.max_iterations = iterations;
    return drag(fraction, limits);
  }
  const auto start = Clock::now();
  State& st = s.state;
  const Eigen::MatrixXd P = st.handles.targets(s.rest_vertices, fraction);
  if (s.guarded() && !s.valid_before_preview) s.valid_before_preview = st.X;
  if (!s.preview_anchored) {
    // The hard rows of X are its handles' targets: at rest there, X moves only as the targets do.
    hierarchy->anchor_preview(st.X, s.current_rows(st.handles));
    s.preview_anchored = true;
  }
  double step_ahead = 0; // how far the new targets lie along the last change of targets (as drag())
  if (s.options.extrapolate && s.before.valid) {
    const Eigen::MatrixXd last = st.targets - s.before.targets;
    const double length = last.squaredNorm();
    if (length > 0) step_ahead = (P - st.targets).cwiseProduct(last).sum() / length;
  }
  s.before = Before{true, st.X, st.targets, st.fraction, st.version_of_last};
  hierarchy->preview(st.X, P, iterations, step_ahead);
  st.targets = P;
  st.fraction = fraction;
  st.version_of_last = st.motion_version;
  PoseStepReport step;
  step.fraction = fraction;
  step.iterations = iterations;
  step.energy = std::numeric_limits<double>::quiet_NaN();
  step.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return step;
}

PoseStepReport DragSession::settle(const std::optional<SolveOptions>& options) {
  return *settle(options, {});
}

namespace {
struct Interrupted {}; // thrown from the solver's progress callback to end a settle early
struct Settled {};     // thrown from it when the settle's stop rule holds

/// When a settle may stop: when the energy still to lose, estimated from how the decrease shrinks
/// (geometrically: d rho / (1 - rho) after a decrease d over two outer iterations that was rho times
/// the one before), plus the last decrease, is below `tolerance` times the energy. The solver's own
/// rule (one iteration's decrease below tolerance times the energy) stops a slowly converging tail
/// far from the minimum, how far depending on where the settle began, i.e. on how many drag events
/// the machine's speed let through; this one stops at the same distance wherever it began.
/// Pairs of iterations: the hierarchical solver's coarse passes come every second one.
class SettleRule {
public:
  explicit SettleRule(double tolerance) : tolerance_(tolerance) {}
  bool done(double energy) {
    energies_.push_back(energy);
    const std::size_t k = energies_.size() - 1;
    if (!(energy > 0)) return true;
    if (k < 4) return false;
    const double last = energies_[k - 2] - energies_[k], before = energies_[k - 4] - energies_[k - 2];
    if (!(last > 0)) return true; // no progress over two iterations: converged to round-off
    if (!(last < before)) return false;
    const double rho = last / before;
    return last / (1 - rho) <= tolerance_ * energy;
  }

private:
  double tolerance_;
  std::vector<double> energies_;
};
} // namespace

std::optional<PoseStepReport> DragSession::settle(const std::optional<SolveOptions>& options,
                                                  const std::function<bool()>& interrupt) {
  Impl& s = *impl_;
  s.ensure_solver();
  s.preview_anchored = false;
  State& st = s.state;
  const Eigen::MatrixXd P = st.handles.targets(s.rest_vertices, st.fraction);
  SolveOptions limits = options.value_or(s.options.solve);
  s.last_limits = limits;
  if (interrupt)
    limits.progress = [&interrupt, progress = std::move(limits.progress)](int it, double energy, double seconds) {
      if (progress) progress(it, energy, seconds);
      if (interrupt()) throw Interrupted{};
    };
  // The state moves towards P either way (an interrupted solve keeps its iterate; a guarded one
  // goes back to the last valid state).
  if (st.motion_version != st.version_of_last) { // new motions since the last event: this solve is one
    s.before.valid = false;
    st.version_of_last = st.motion_version;
  }
  st.targets = P;
  SolveResult r;
  ValidStep valid;
  // After unguarded previews the guarded solve starts from the last valid state.
  const Eigen::MatrixXd from = !s.guarded() ? Eigen::MatrixXd() : s.valid_before_preview ? *s.valid_before_preview : st.X;
  // The hierarchical solver updates X in place: it runs to the settle's stop rule unguarded first,
  // the guarded solve then starts there (and certifies it). The single-level solver keeps its own rule.
  const bool in_place = s.solver->hierarchical() != nullptr;
  int rule_iterations = 0;
  double rule_seconds = 0;
  bool rule_held = !in_place;
  try {
    if (in_place) {
      SettleRule rule(limits.tolerance);
      SolveOptions to_rule = limits;
      to_rule.tolerance = 0; // the rule decides, also when the energy no longer falls
      to_rule.progress = [&, progress = limits.progress](int it, double energy, double seconds) {
        if (progress) progress(it, energy, seconds);
        rule_iterations = it;
        rule_seconds = seconds;
        if (rule.done(energy)) throw Settled{};
      };
      try {
        const SolveResult first = s.solver->solve(st.X, P, to_rule);
        rule_iterations = first.iterations;
        rule_seconds = first.seconds;
        rule_held = first.converged;
      } catch (const Settled&) {
        rule_held = true;
      }
    }
    const auto solve_start = Clock::now();
    r = !s.guarded() ? (in_place ? SolveResult{} : s.solver->solve(st.X, P, limits))
                     : s.solver->solve_valid(from, st.X, P, limits, s.options.guard, &valid);
    // A guarded solve's seconds are the whole of it (mend, drag, certificate; SolveResult's are
    // the solver's alone), but for building the guard, which is setup.
    if (s.guarded())
      r.seconds = std::chrono::duration<double>(Clock::now() - solve_start).count() - valid.guard_setup_seconds;
  } catch (const Interrupted&) {
    if (s.guarded()) st.X = from;
    s.valid_before_preview.reset();
    return std::nullopt;
  }
  if (!s.guarded() && in_place) { // the rule's solve is the settle
    r.converged = true;
    r.energy = {s.solver->energy(st.X, P)};
  }
  r.iterations += rule_iterations;
  r.seconds += rule_seconds;
  r.converged = r.converged && rule_held;
  s.valid_before_preview.reset();
  s.record(st.fraction, r, r.seconds);
  return s.options.allow_invalid ? s.state.steps.back() : s.mark_guarded(valid);
}

const Shell& DragSession::rest() const { return impl_->rest; }
const Eigen::MatrixXd& DragSession::vertices() const { return impl_->state.X; }
double DragSession::fraction() const { return impl_->state.fraction; }

void DragSession::checkpoint() {
  if (impl_->undo_depth <= 0) return;
  impl_->undo.push_back(impl_->state);
  while (impl_->undo.size() > static_cast<size_t>(impl_->undo_depth)) impl_->undo.pop_front();
}

void DragSession::set_undo_depth(int depth) {
  if (depth < 0)
    throw InputError("DragSession::set_undo_depth: the depth must be >= 0 (got " + std::to_string(depth) + ")");
  impl_->undo_depth = depth;
  while (impl_->undo.size() > static_cast<size_t>(impl_->undo_depth)) impl_->undo.pop_front();
}

bool DragSession::undo() {
  Impl& s = *impl_;
  if (s.undo.empty()) return false;
  s.state = std::move(s.undo.back());
  s.undo.pop_back();
  s.before.valid = false;
  s.preview_anchored = false;
  s.valid_before_preview.reset(); // checkpoints hold settled states
  return true;
}

void DragSession::reset() {
  checkpoint();
  Impl& s = *impl_;
  State& st = s.state;
  for (Handle& h : st.handles.handles) {
    h.translate.setZero();
    h.degrees = 0;
  }
  st.X = s.rest_vertices;
  st.fraction = 0;
  ++st.motion_version;
  st.version_of_last = st.motion_version;
  st.targets = s.current_rows(st.handles);
  st.steps.clear();
  s.before.valid = false;
  s.preview_anchored = false;
  s.valid_before_preview.reset();
}

int DragSession::solver_builds() const { return impl_->builds; }

int DragSession::solver_levels() const {
  if (!impl_->solver) return 0;
  const HierarchicalSolver* hierarchy = impl_->solver->hierarchical();
  return hierarchy ? hierarchy->num_levels() : 1;
}

const RestTets& DragSession::rest_tets() const { return impl_->tets(); }

void DragSession::prepare() { impl_->ensure_solver(); }

std::size_t DragSession::result_step_count() const { return impl_->state.steps.size(); }

PoseResult DragSession::result(std::size_t first_step) const {
  const Impl& s = *impl_;
  const State& st = s.state;
  PoseResult r;
  r.X = st.X;
  if (first_step < st.steps.size()) r.steps.assign(st.steps.begin() + static_cast<std::ptrdiff_t>(first_step), st.steps.end());
  r.setup_seconds = s.solver ? s.solver->setup_seconds() : 0;
  r.stretch = stretch_stats(s.tets(), st.X);
  r.shell = s.shell_name;
  r.handles = s.handles_name;
  r.solver = s.options.solver;
  const int built = solver_levels();
  r.levels = built > 0 ? built : s.options.levels_asked();
  r.mode = st.handles.mode;
  r.weight = st.handles.weight;
  r.thickness = s.rest.thickness;
  r.tets = s.tets().size();
  r.handle_vertices = static_cast<int>(st.handles.constrained_vertices().size());
  r.tolerance = s.last_limits.tolerance;
  r.max_iterations = s.last_limits.max_iterations;
  return r;
}

nlohmann::ordered_json DragSession::handles_json() const { return handles_to_json(impl_->state.handles); }

void DragSession::write(const std::string& dir, std::size_t first_step, const BeforeCommit& before_commit) const {
  const Impl& s = *impl_;
  check_pose_output_folder(dir, s.shell_name);
  ShellFolderContents c;
  c.surface = s.surface;
  c.X = s.state.X;
  c.cell_data.emplace_back("stretch", tet_stretch(s.tets(), c.X));
  c.cell_data.emplace_back("det_F", tet_deformation_determinants(s.tets(), c.X));
  c.report = result(first_step).to_json();
  // "shell" is the rest shell as it was named, relative to where the pose ran; readers of the
  // folder (report, preview) find it from the folder itself, wherever they run.
  std::error_code ec;
  if (!s.shell_name.empty() && is_shell_folder(s.shell_name)) {
    // Absolute first: a relative path none of whose parts exists yet comes back unresolved.
    const fs::path rest = fs::weakly_canonical(fs::absolute(s.shell_name), ec);
    const fs::path out = ec ? fs::path() : fs::weakly_canonical(fs::absolute(dir), ec);
    if (!ec) c.report["rest_shell"] = rest.lexically_relative(out).generic_string();
  }
  write_shell_folder(dir, c, before_commit);
}

void check_pose_output_folder(const std::string& dir, const std::string& shell_dir) {
  std::error_code ec;
  if (!shell_dir.empty() && fs::exists(dir, ec) && fs::equivalent(dir, shell_dir, ec))
    throw InputError(with_file(dir, "is the folder of the rest shell being posed; choose another output folder"));
  check_output_folder(dir, [](const fs::path& d) { return holds_shell_output_of(d, "pose"); });
}

} // namespace gshell
