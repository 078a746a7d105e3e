// The drag session (run/drag_session.h): what `gshell pose --steps`, Python's Poser and the viewer
// drive. A scripted drag reaches what run_pose reaches, undo and reset restore states, and only a
// change of the handles' vertex sets rebuilds the solver.
#include "shell_fixtures.h"
#include "test_support.h"

#include <gshell/deform/handles.h>
#include <gshell/error.h>
#include <gshell/quality/shell_certificate.h>
#include <gshell/quality/stretch.h>
#include <gshell/run/drag_session.h>
#include <gshell/run/pose_run.h>
#include <gshell/run/shell_folder.h>

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <filesystem>

using namespace gshell;

namespace {

/// Both surfaces' vertices whose rest x lies beyond `x` (from the side `sign` points to).
std::vector<int> strip_end(const Shell& shell, double x, double sign) {
  const Eigen::MatrixXd X = shell.vertices();
  std::vector<int> ids;
  for (int v = 0; v < X.rows(); ++v)
    if (sign * (X(v, 0) - x) > 0) ids.push_back(v);
  return ids;
}

/// A flat plate held at its -x end and lifted and turned at its +x end: a bend.
struct Plate {
  Shell shell = test::flat_plane_shell(10, 0.1);
  HandleSet handles;
  Eigen::Vector3d lift{0, 0, 0.6};
  Plate() {
    Handle hold, pull;
    hold.name = "hold";
    hold.vertices = strip_end(shell, -0.75, -1);
    pull.name = "pull";
    pull.vertices = strip_end(shell, 0.75, 1);
    for (Handle* h : {&hold, &pull}) {
      h->center.setZero();
      for (int v : h->vertices) h->center += shell.vertices().row(v).transpose() / static_cast<double>(h->vertices.size());
    }
    pull.translate = lift;
    pull.axis = Eigen::Vector3d::UnitY();
    pull.degrees = -30;
    handles.handles = {hold, pull};
  }
};

PoseOptions tight(PoseSolverKind kind) {
  PoseOptions o;
  o.solver = kind;
  o.hierarchy.levels = 3;
  o.solve.max_iterations = 20000;
  o.solve.tolerance = 1e-12;
  return o;
}

double max_distance(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).rowwise().norm().maxCoeff();
}

} // namespace

TEST(DragSession, ScriptedDragReachesWhatRunPoseReaches) {
  const Plate plate;
  for (PoseSolverKind kind : {PoseSolverKind::Single, PoseSolverKind::Hierarchical}) {
    PoseOptions o = tight(kind);
    o.steps = 4;
    const PoseResult reference = run_pose(plate.shell, plate.handles, o);

    // The viewer's way: hold-only handles first, then per-event targets (quick solves), then rest.
    DragSession session(plate.shell, o);
    HandleSet still = plate.handles;
    still.handles[1].translate.setZero();
    still.handles[1].degrees = 0;
    session.set_handles(still);
    SolveOptions quick;
    quick.max_iterations = 3;
    for (int event = 1; event <= 12; ++event) {
      const double t = event / 12.0;
      session.set_motion(1, t * plate.lift, Eigen::Vector3d::UnitY(), -30 * t);
      const PoseStepReport step = session.drag(1.0, quick);
      EXPECT_LE(step.iterations, 3);
    }
    const PoseStepReport settled = session.settle();
    EXPECT_TRUE(settled.converged);
    EXPECT_EQ(session.solver_builds(), 1);
    // The same minimum, to the solvers' tolerance (the plate is 2 wide, 0.1 thick).
    EXPECT_LT(max_distance(session.vertices(), reference.X), 1e-5) << pose_solver_name(kind);
    const PoseResult mine = session.result();
    EXPECT_NEAR(mine.stretch.volume_mean, reference.stretch.volume_mean, 1e-6 * reference.stretch.volume_mean);
    EXPECT_EQ(mine.steps.size(), 13u);
    // Hard handles sit on their targets.
    const Eigen::MatrixXd P = plate.handles.targets(plate.shell.vertices(), 1.0);
    const std::vector<int> ids = plate.handles.constrained_vertices();
    for (size_t r = 0; r < ids.size(); ++r) EXPECT_LT((session.vertices().row(ids[r]) - P.row(r)).norm(), 1e-12);
  }
}

TEST(DragSession, RunPoseIsTheFractionDrag) {
  // run_pose is K drag events at k/K of the handles' motion: the same steps, the same state.
  const Plate plate;
  PoseOptions o;
  o.solver = PoseSolverKind::Single;
  o.steps = 3;
  // Each step is reported as it ends: before the next step's first iteration.
  std::vector<std::pair<int, int>> events; // (step, iteration); iteration -1: the step's end
  std::vector<PoseStepReport> ended;
  o.step_progress = [&](int step, int it, double, double) { events.emplace_back(step, it); };
  o.step_done = [&](int step, const PoseStepReport& s) {
    events.emplace_back(step, -1);
    ended.push_back(s);
  };
  const PoseResult r = run_pose(plate.shell, plate.handles, o);
  ASSERT_EQ(ended.size(), 3u);
  for (std::size_t e = 1; e < events.size(); ++e) {
    EXPECT_GE(events[e].first, events[e - 1].first);
    if (events[e].first > events[e - 1].first) EXPECT_EQ(events[e - 1].second, -1) << "step " << events[e].first;
  }
  DragSession session(plate.shell, o);
  session.set_handles(plate.handles);
  for (int k = 1; k <= 3; ++k) session.drag(k / 3.0);
  EXPECT_EQ(session.vertices(), r.X);
  ASSERT_EQ(r.steps.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(r.steps[k].iterations, session.result().steps[k].iterations);
    EXPECT_EQ(ended[k].iterations, r.steps[k].iterations);
    EXPECT_DOUBLE_EQ(r.steps[k].fraction, (k + 1) / 3.0);
  }
  EXPECT_EQ(session.fraction(), 1.0);
}

TEST(DragSession, StepsInvalidOnlyWhereTheRestShellIsSayItIsTheRestShells) {
  // An --allow-invalid or offset rest shell keeps its faults through a pose: the guard leaves them
  // out. Such steps are named for what they are, not as steps the guard could not make valid.
  Plate plate;
  PoseOptions o;
  o.steps = 2;
  const PoseResult clean = run_pose(plate.shell, plate.handles, o);
  ASSERT_EQ(clean.steps.size(), 2u);
  for (const PoseStepReport& s : clean.steps) {
    EXPECT_TRUE(s.valid);
    EXPECT_FALSE(s.rest_faults_only);
  }
  EXPECT_TRUE(clean.warnings().empty());

  // A held top vertex pushed through its base: its prisms' tets invert, and stay so (a free one
  // the solver pulls back, against the rest tets' ideal shape).
  int held = 0;
  (plate.shell.base.rowwise() - Eigen::RowVector3d(-0.9, 0, 0)).rowwise().norm().minCoeff(&held);
  const std::vector<int>& hold = plate.handles.handles[0].vertices;
  ASSERT_TRUE(std::binary_search(hold.begin(), hold.end(), plate.shell.num_base_vertices() + held));
  plate.shell.top(held, 2) = -0.5 * plate.shell.thickness;
  ASSERT_GT(certify_shell(plate.shell.base, plate.shell.top, plate.shell.F).inverted_tets, 0);
  const PoseResult r = run_pose(plate.shell, plate.handles, o);
  ASSERT_EQ(r.steps.size(), 2u);
  for (const PoseStepReport& s : r.steps) {
    EXPECT_FALSE(s.valid);
    EXPECT_GT(s.inverted_tets, 0);
    EXPECT_TRUE(s.rest_faults_only);
    EXPECT_TRUE(s.to_json()["rest_faults_only"].get<bool>());
  }
  const std::vector<std::string> w = r.warnings();
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0], "2 of 2 pose steps are not valid: pose steps 1, 2 keep the rest shell's own faults (report.json "
                  "has each pose step's certificate)");
}

TEST(DragSession, UndoAndResetRestoreStates) {
  const Plate plate;
  PoseOptions o;
  o.solver = PoseSolverKind::Single;
  DragSession session(plate.shell, o);
  EXPECT_FALSE(session.undo()); // nothing to undo yet
  session.set_handles(plate.handles);
  session.drag(0.5);
  const Eigen::MatrixXd half = session.vertices();
  const std::size_t steps = session.result_step_count();

  session.checkpoint(); // a drag begins
  session.drag(1.0);
  EXPECT_GT(max_distance(session.vertices(), half), 0.1);
  ASSERT_TRUE(session.undo());
  EXPECT_EQ(session.vertices(), half);
  EXPECT_EQ(session.result_step_count(), steps);
  EXPECT_EQ(session.fraction(), 0.5);

  session.reset();
  EXPECT_EQ(session.vertices(), plate.shell.vertices());
  EXPECT_EQ(session.result_step_count(), 0u);
  for (const Handle& h : session.handles().handles) {
    EXPECT_TRUE(h.translate.isZero(0));
    EXPECT_EQ(h.degrees, 0);
  }
  // A drag after reset moves nothing (the motions are cleared).
  session.drag(1.0);
  EXPECT_LT(max_distance(session.vertices(), plate.shell.vertices()), 1e-9);
  ASSERT_TRUE(session.undo()); // back before the reset
  EXPECT_EQ(session.vertices(), half);
  EXPECT_EQ(session.handles(), plate.handles);

  // An edit of the handles is an undo point too.
  session.remove_handle(1);
  EXPECT_EQ(session.handles().handles.size(), 1u);
  ASSERT_TRUE(session.undo());
  EXPECT_EQ(session.handles(), plate.handles);

  session.set_undo_depth(0);
  session.checkpoint();
  EXPECT_FALSE(session.undo());
  // A negative depth is a caller's mistake, not "none".
  EXPECT_THROW(session.set_undo_depth(-5), InputError);
}

TEST(DragSession, OnlyNewVertexSetsRebuildTheSolver) {
  const Plate plate;
  PoseOptions o;
  o.solver = PoseSolverKind::Hierarchical;
  o.hierarchy.levels = 3;
  DragSession session(plate.shell, o);
  EXPECT_EQ(session.solver_builds(), 0);
  session.set_handles(plate.handles);
  EXPECT_EQ(session.solver_builds(), 0); // built lazily, at the first solve
  session.drag(0.3);
  EXPECT_EQ(session.solver_builds(), 1);
  for (int k = 0; k < 5; ++k) {
    session.set_motion(1, Eigen::Vector3d(0.1 * k, 0, 0.2), Eigen::Vector3d::UnitZ(), 5.0 * k);
    session.drag();
  }
  session.settle();
  HandleSet moved = plate.handles; // other motions, same vertices
  moved.handles[0].translate = Eigen::Vector3d(0, 0.1, 0);
  session.set_handles(moved);
  session.drag();
  EXPECT_EQ(session.solver_builds(), 1);

  // A vertex more in a group, a group more, soft mode: each needs a new factorisation.
  std::vector<int> wider = plate.handles.handles[0].vertices;
  wider.push_back(strip_end(plate.shell, -0.5, -1).back());
  session.set_handle_vertices(0, wider);
  session.drag();
  EXPECT_EQ(session.solver_builds(), 2);
  Handle middle;
  int centre = 0;
  plate.shell.base.rowwise().norm().minCoeff(&centre);
  middle.vertices = {centre};
  const int index = session.add_handle(middle);
  EXPECT_EQ(index, 2);
  EXPECT_EQ(session.handles().handles[2].center, plate.shell.base.row(centre).transpose()); // rest centroid
  session.drag();
  EXPECT_EQ(session.solver_builds(), 3);
  HandleSet soft = session.handles();
  soft.mode = ConstraintMode::Soft;
  session.set_handles(soft);
  session.drag();
  EXPECT_EQ(session.solver_builds(), 4);
}

TEST(DragSession, RigidMotionOfEverythingMovesTheShellRigidly) {
  const Plate plate;
  DragSession session(plate.shell, tight(PoseSolverKind::Single));
  Handle all;
  for (int v = 0; v < 2 * plate.shell.num_base_vertices(); ++v) all.vertices.push_back(v);
  session.add_handle(all);
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, 3).normalized(), shift(0.5, -1, 2);
  session.set_motion(0, shift, axis, 70);
  session.drag();
  const Eigen::Matrix3d R = Eigen::AngleAxisd(70 * M_PI / 180, axis).toRotationMatrix();
  const Eigen::Vector3d c = session.handles().handles[0].center;
  const Eigen::MatrixXd X = plate.shell.vertices();
  for (int v = 0; v < X.rows(); ++v)
    EXPECT_LT((session.vertices().row(v).transpose() - (R * (X.row(v).transpose() - c) + c + shift)).norm(), 1e-12);
  EXPECT_LT(session.result().stretch.max, 1e-20);
}

TEST(DragSession, HandlesJsonIsTheHandleFileFormat) {
  const Plate plate;
  DragSession session(plate.shell);
  session.set_handles(plate.handles);
  session.set_motion(1, Eigen::Vector3d(0.1, 0.2, 0.3), Eigen::Vector3d(1, 1, 0), 12.5);
  const HandleSet back = parse_handles(session.handles_json().dump(), "session", plate.shell);
  ASSERT_EQ(back.handles.size(), 2u);
  EXPECT_EQ(back.mode, ConstraintMode::Hard);
  for (int k = 0; k < 2; ++k) {
    const Handle &a = session.handles().handles[k], &b = back.handles[k];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.vertices, b.vertices);
    EXPECT_EQ(a.translate, b.translate);
    EXPECT_EQ(a.center, b.center);
    EXPECT_EQ(a.degrees, b.degrees);
    EXPECT_LT((a.axis - b.axis).norm(), 1e-15);
  }
  // Same targets from the file as from the session.
  const Eigen::MatrixXd X = plate.shell.vertices();
  EXPECT_LT(max_distance(back.targets(X, 1.0), session.handles().targets(X, 1.0)), 1e-14);
}

TEST(DragSession, UnguardedStepsAreCertifiedInTheResultAndTheWrittenReport) {
  // allow_invalid: the steps are the solver's own, each still certified, as deform's unguarded
  // frames are; the folder's report.json (what `pose --allow-invalid` and Poser.write write) says so
  // (it listed only iterations and energy, and no warning).
  const Plate plate;
  PoseOptions o;
  o.solver = PoseSolverKind::Single;
  o.allow_invalid = true;
  o.steps = 2;
  DragSession session(plate.shell, o);
  session.set_handles(plate.handles);
  const PoseResult r = run_pose(session, o);
  ASSERT_EQ(r.steps.size(), 2u);
  for (const PoseStepReport& s : r.steps) {
    EXPECT_FALSE(s.guarded);
    EXPECT_TRUE(s.certified);
  }
  test::TempDir tmp;
  session.write(tmp.file("posed"));
  const auto report = read_report(tmp.file("posed"));
  ASSERT_EQ(report["steps"].size(), 2u);
  for (const auto& step : report["steps"]) {
    EXPECT_EQ(step["method"], "unguarded") << step.dump();
    EXPECT_TRUE(step.contains("valid") && step.contains("certificate")) << step.dump();
  }
}

TEST(DragSession, WritesThePoseFolder) {
  const Plate plate;
  PoseOptions o;
  o.solver = PoseSolverKind::Single;
  TriMesh surface = make_plane(10);
  DragSession session(plate.shell, o, surface);
  session.set_names("rest-shell", "drag.json");
  session.set_handles(plate.handles);
  session.drag(1.0);
  test::TempDir tmp;
  const std::string out = tmp.file("posed");
  session.write(out);
  const ShellFolder folder = read_shell_folder(out, {true, true});
  EXPECT_EQ(folder.made_by, "pose");
  EXPECT_DOUBLE_EQ(folder.shell.thickness, plate.shell.thickness);
  EXPECT_LT(max_distance(folder.shell.vertices(), session.vertices()), 1e-12);
  EXPECT_TRUE(folder.surface.has_uv()); // the plane's UVs went along
  ASSERT_EQ(folder.tet_stretch.size(), 3 * plate.shell.F.rows());
  EXPECT_NEAR(folder.tet_stretch.maxCoeff(), session.result().stretch.max, 1e-12);
  const auto report = read_report(out);
  EXPECT_EQ(report["shell"], "rest-shell");
  EXPECT_EQ(report["handles"], "drag.json");
  EXPECT_EQ(report["steps"].size(), 1u);
  EXPECT_EQ(report["inverted_tets"], 0);
  // An earlier output is replaced; a folder of other files is refused.
  session.drag(0.5);
  session.write(out);
  EXPECT_EQ(read_report(out)["steps"].size(), 2u);
  std::filesystem::create_directory(tmp.path() / "other");
  test::write_text(tmp.file("other/notes.txt"), "keep me");
  EXPECT_THROW(session.write(tmp.file("other")), InputError);
  EXPECT_EQ(test::read_text(tmp.file("other/notes.txt")), "keep me");
  EXPECT_EQ(test::count_entries(tmp.path()), 2); // posed, other: no staging folder left
}

TEST(DragSession, BadInputIsAnInputErrorAndChangesNothing) {
  const Plate plate;
  DragSession session(plate.shell);
  session.set_handles(plate.handles);
  const HandleSet before = session.handles();
  HandleSet overlap = plate.handles;
  overlap.handles[1].vertices.push_back(overlap.handles[0].vertices.front());
  EXPECT_THROW(session.set_handles(overlap), InputError);
  HandleSet out_of_range = plate.handles;
  out_of_range.handles[0].vertices.push_back(2 * plate.shell.num_base_vertices());
  EXPECT_THROW(session.set_handles(out_of_range), InputError);
  EXPECT_THROW(session.set_motion(5, Eigen::Vector3d::Zero()), InputError);
  EXPECT_THROW(session.set_motion(1, Eigen::Vector3d(NAN, 0, 0)), InputError);
  EXPECT_THROW(session.set_motion(1, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 10), InputError);
  EXPECT_THROW(session.drag(NAN), InputError);
  EXPECT_EQ(session.handles(), before);
  // A hold on one end only of two separate plates leaves the other free.
  Shell two = plate.shell;
  const int n = plate.shell.num_base_vertices();
  two.base.resize(2 * n, 3);
  two.top.resize(2 * n, 3);
  two.base << plate.shell.base, plate.shell.base.rowwise() + Eigen::RowVector3d(5, 0, 0);
  two.top << plate.shell.top, plate.shell.top.rowwise() + Eigen::RowVector3d(5, 0, 0);
  two.F.resize(2 * plate.shell.F.rows(), 3);
  two.F << plate.shell.F, plate.shell.F.array() + n;
  DragSession free(two);
  Handle hold;
  hold.vertices = {0, 1, 2};
  free.add_handle(hold);
  EXPECT_THROW(free.drag(), InputError);
  EXPECT_THROW(DragSession(Shell{}), InputError);
  PoseOptions bad;
  bad.steps = 0;
  EXPECT_THROW(DragSession(plate.shell, bad), InputError);
}

TEST(DragSession, EventsStartFromTheDragsMotionContinued) {
  // Targets moved by the caller (not a fraction of a fixed motion): the start of each event
  // continues the last change (PoseSolver::predict_start with the step measured on the targets).
  // With one iteration per event, the extrapolated drag stays nearer the moving minimum.
  const Plate plate;
  double energy[2];
  for (int k = 0; k < 2; ++k) {
    PoseOptions o;
    o.solver = PoseSolverKind::Single;
    o.extrapolate = k == 1;
    DragSession session(plate.shell, o);
    session.set_handles(plate.handles);
    session.set_motion(1, Eigen::Vector3d::Zero());
    SolveOptions one;
    one.max_iterations = 1;
    PoseStepReport last;
    for (int event = 1; event <= 10; ++event) {
      session.set_motion(1, event / 10.0 * plate.lift);
      last = session.drag(1.0, one);
    }
    energy[k] = last.energy;
  }
  EXPECT_LT(energy[1], 0.8 * energy[0]) << "plain " << energy[0] << ", extrapolated " << energy[1];
}

TEST(DragSession, AnInterruptedSettleKeepsAStateAndTheNextOneFinishesTheJob) {
  // The viewer's rest: settle until the next event comes. Interrupted after a few iterations,
  // nothing is recorded, the state is no worse than before, and a later settle reaches the
  // same minimum as one uninterrupted settle.
  const Plate plate;
  for (PoseSolverKind kind : {PoseSolverKind::Hierarchical, PoseSolverKind::Single}) {
    PoseOptions o = tight(kind);
    o.solve.tolerance = 1e-10;
    DragSession whole(plate.shell, o), parts(plate.shell, o);
    for (DragSession* s : {&whole, &parts}) {
      s->set_handles(plate.handles);
      s->drag(1.0, SolveOptions{1, 1e-10, {}});
    }
    ASSERT_EQ(whole.vertices(), parts.vertices());
    const PoseStepReport full = whole.settle();
    ASSERT_TRUE(full.converged);

    const std::size_t steps = parts.result_step_count();
    const double before = whole.result(0).steps.front().energy;
    int asked = 0;
    const std::optional<PoseStepReport> cut = parts.settle(std::nullopt, [&asked] { return ++asked == 3; });
    EXPECT_FALSE(cut.has_value());
    EXPECT_EQ(asked, 3); // asked after every iteration, stopped at the first yes
    EXPECT_EQ(parts.result_step_count(), steps);
    PoseSolver check(plate.shell, parts.handles(), kind, o.hierarchy);
    EXPECT_LE(check.energy(parts.vertices(), 1.0), before * (1 + 1e-12)) << pose_solver_name(kind);

    const std::optional<PoseStepReport> rest = parts.settle(std::nullopt, [] { return false; });
    ASSERT_TRUE(rest.has_value());
    EXPECT_TRUE(rest->converged);
    EXPECT_LT(max_distance(parts.vertices(), whole.vertices()), 1e-5) << pose_solver_name(kind);
  }
}

TEST(DragSession, PrepareBuildsTheSolverAheadOfTheFirstEvent) {
  const Plate plate;
  DragSession session(plate.shell, tight(PoseSolverKind::Hierarchical));
  session.set_handles(plate.handles);
  EXPECT_EQ(session.solver_builds(), 0);
  session.prepare();
  EXPECT_EQ(session.solver_builds(), 1);
  session.prepare(); // nothing changed: nothing to build
  session.drag(0.5);
  EXPECT_EQ(session.solver_builds(), 1);
  // The rest tets are the solver's: one per prism tet, positive rest volumes.
  EXPECT_EQ(session.rest_tets().size(), 3 * plate.shell.F.rows());
  EXPECT_GT(session.rest_tets().volume.minCoeff(), 0);
}

TEST(DragSession, PreviewsMoveTheShellFromTheDragsStartAndTheSettleFinishesIt) {
  // The viewer's events: the hierarchy's finest reduced level moves the shell from where the drag
  // began, with no full-level work; the settle then reaches what run_pose reaches.
  const Plate plate;
  PoseOptions o = tight(PoseSolverKind::Hierarchical);
  o.steps = 4;
  const PoseResult reference = run_pose(plate.shell, plate.handles, o);
  o.guard_drag_steps = false; // as the viewer: events are unguarded previews, the settle is guarded
  DragSession session(plate.shell, o);
  HandleSet still = plate.handles;
  still.handles[1].translate.setZero();
  still.handles[1].degrees = 0;
  session.set_handles(still);
  const Eigen::MatrixXd rest = plate.shell.vertices();

  // Targets where the shell is: it stays (the level is at rest at its anchor).
  session.preview();
  EXPECT_LT(max_distance(session.vertices(), rest), 1e-12);
  // Both groups shifted alike: a translation, in the level's subspace and free of energy.
  const Eigen::Vector3d shift(0.2, -0.1, 0.3);
  session.set_motion(0, shift);
  session.set_motion(1, shift);
  session.preview();
  for (int v = 0; v < rest.rows(); ++v)
    EXPECT_LT((session.vertices().row(v) - rest.row(v) - shift.transpose()).norm(), 1e-9) << v;
  session.reset();

  const std::size_t steps = session.result_step_count();
  const std::vector<int> ids = plate.handles.constrained_vertices();
  for (int event = 1; event <= 12; ++event) {
    const double t = event / 12.0;
    session.set_motion(1, t * plate.lift, Eigen::Vector3d::UnitY(), -30 * t);
    const PoseStepReport step = session.preview(1.0, 1);
    EXPECT_EQ(step.iterations, 1);
    ASSERT_TRUE(session.vertices().allFinite());
    // Hard handles sit on their targets after every event.
    const Eigen::MatrixXd P = session.handles().targets(rest, 1.0);
    for (size_t r = 0; r < ids.size(); ++r) EXPECT_LT((session.vertices().row(ids[r]) - P.row(r)).norm(), 1e-12);
  }
  EXPECT_EQ(session.result_step_count(), steps); // previews are no steps of the pose
  // The last preview moved the free vertices along (the plate bends), not only the handles.
  int moved = 0;
  for (int v = 0; v < rest.rows(); ++v)
    if (!std::binary_search(ids.begin(), ids.end(), v) && (session.vertices().row(v) - rest.row(v)).norm() > 0.05) ++moved;
  EXPECT_GT(moved, rest.rows() / 4);
  const PoseStepReport settled = session.settle();
  EXPECT_TRUE(settled.converged);
  EXPECT_EQ(session.solver_builds(), 1);
  EXPECT_LT(max_distance(session.vertices(), reference.X), 1e-5);
}

TEST(DragSession, TheSettleStopsNearTheMinimumWhereverItBegins) {
  // The settle's stop rule is about the energy still to lose, not about one iteration's gain: from
  // a far start (one preview jumping to the targets) and from a near one (after 12 quick events) it ends within
  // a few tolerances of the minimum.
  const Plate plate;
  PoseOptions reference_options = tight(PoseSolverKind::Single);
  reference_options.solve.tolerance = 1e-13;
  DragSession reference(plate.shell, reference_options);
  reference.set_handles(plate.handles);
  reference.drag();
  const double minimum = reference.result().steps.back().energy;
  for (int events : {1, 12}) {
    PoseOptions o = tight(PoseSolverKind::Hierarchical);
    o.solve.tolerance = 1e-6;
    o.solve.max_iterations = 500;
    o.guard_drag_steps = false;
    DragSession session(plate.shell, o);
    HandleSet h = plate.handles;
    session.set_handles(h);
    for (int event = 1; event <= events; ++event) {
      const double t = event / static_cast<double>(events);
      session.set_motion(1, t * plate.lift, Eigen::Vector3d::UnitY(), -30 * t);
      session.preview(1.0, 1);
    }
    const PoseStepReport settled = session.settle();
    EXPECT_TRUE(settled.converged) << events;
    EXPECT_LE(settled.energy, minimum * (1 + 3e-6)) << events << " events: " << settled.energy << " vs " << minimum;
    EXPECT_GE(settled.energy, minimum * (1 - 1e-9)) << events;
  }
}
