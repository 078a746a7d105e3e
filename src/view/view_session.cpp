#include <gshell/view/view_session.h>

#include <gshell/deform/handles.h>
#include <gshell/error.h>
#include <gshell/quality/certificate_report.h>
#include <gshell/quality/stretch.h>
#include <gshell/render/color_map.h>
#include <gshell/render/shell_render.h>

#include "geometry/power_of_two_unit.h"


#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>

namespace gshell {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

namespace {

constexpr int kProtocolVersion = 1;
/// Ramp samples sent to the page: the render's ramps are piecewise linear with a stop at 1/2, so
/// linear interpolation between 65 samples reproduces them exactly.
constexpr int kRampSamples = 65;
/// A handle may move at most this many bounding radii (beyond, the solve is meaningless and
/// float32 positions lose the shape).
constexpr double kMaxMotionRadii = 1e3;

ojson scale_json(const ColorScale& scale, const std::string& footnote) {
  ojson ramp = ojson::array();
  for (int k = 0; k < kRampSamples; ++k) {
    const Eigen::Vector3f c = scale.ramp_color(static_cast<double>(k) / (kRampSamples - 1));
    ramp.insert(ramp.end(), {c.x(), c.y(), c.z()});
  }
  const Eigen::Vector3f nan = scale.color(std::nan(""));
  return {{"min", scale.min}, {"max", scale.max}, {"label", scale.label}, {"ramp", ramp},
          {"nan", {nan.x(), nan.y(), nan.z()}}, {"footnote", footnote}};
}

ojson message(const char* type) { return ojson{{"type", type}}; }

// Messages may quote what a page sent: bytes that are not UTF-8 become U+FFFD instead of an error.
ViewOutgoing text(const ojson& j, bool to_sender = false) {
  return {j.dump(-1, ' ', false, ojson::error_handler_t::replace), false, to_sender};
}

double bounding_radius(const Eigen::MatrixXd& X) {
  const Eigen::RowVector3d centre = 0.5 * (X.colwise().minCoeff() + X.colwise().maxCoeff());
  return (X.rowwise() - centre).rowwise().norm().maxCoeff();
}

} // namespace

void ViewSessionOptions::check() const {
  pose.check();
  if (event_iterations < 1) throw InputError("event_iterations must be >= 1");
  if (!(values_share >= 0) || !std::isfinite(values_share)) throw InputError("values_share must be a number >= 0");
  std::error_code ec;
  if (!fs::is_directory(output_dir, ec)) throw InputError(with_file(output_dir, "output_dir is not a folder"));
}

struct ViewSession::Impl {
  ViewInput input;
  ViewSessionOptions options;
  std::optional<DragSession> drag;
  std::function<void(const std::string&)> log;
  Eigen::MatrixXd rest_vertices;
  double radius = 1;
  // What the page's positions and handle centres are relative to (hello's "origin"): the centre
  // of the input shell's box, so that float32 keeps the shell's detail wherever it lies.
  Eigen::RowVector3d origin = Eigen::RowVector3d::Zero();
  // Page units per model unit (hello's "unit"): positions, handle centres and translations go to
  // the page as (x - origin) * unit, and drags come back divided by it. 1 for shells of ordinary
  // size; for one whose box diagonal lies outside [1e-6, 1e18], the power of two that brings it
  // into [0.5, 1), so that float32 (range 1.2e-38..3.4e38) and the page's camera keep it.
  double unit = 1;
  int frame = 0; ///< the frame shown (sequences)

  // Drags wait here until solve_drag (coalescing).
  bool pending = false;
  std::uint32_t seq = 0; ///< of the latest drag received
  Clock::time_point received{};
  std::uint32_t answered_seq = 0; ///< of the latest drag solved
  bool settle_pending = false, settle_requested = false, handles_changed = false;

  std::uint64_t version = 0; ///< bumped whenever the shown shell changes

  // Measures of the shown shell, valid while values_version == version.
  std::uint64_t values_version = ~std::uint64_t(0);
  bool at_rest = true;       ///< the shell is the input's (colors: its stored stretch)
  Eigen::VectorXd face_values, vertex_values;
  int inverted_by_det = -1;  ///< posed shells: tets with det F <= 0 against the rest shell
  double values_seconds = -1;///< cost of measuring a posed shell (-1: not known yet)
  std::uint64_t validity_version = ~std::uint64_t(0);
  ojson validity;

  std::optional<PoseStepReport> last_step;
  double last_latency_ms = 0;
  std::string phase = "rest";
  std::string solver_note;

  std::optional<ViewFrame> read_frame; ///< the frame shown when the sequence is not held and it is not the first

  const ViewFrame& shown_frame() const { return read_frame ? *read_frame : input.frames[frame]; } // frame: 0 when posable
  const Eigen::MatrixXd& X() const { return drag ? drag->vertices() : shown_frame().X; }
  int num_base() const { return input.shell.num_base_vertices(); }

  DragSession& posable(const char* type) {
    if (!drag)
      throw InputError(std::string(type) + ": this input is a sequence of frames (a deform output, whose frames are " +
                       "saved already); handles, poses and saving need a single shell");
    return *drag;
  }

  int group(int k) const {
    const int count = static_cast<int>(drag->handles().handles.size());
    if (k < 0 || k >= count)
      throw InputError("no handle group " + std::to_string(k) + " (there are " + std::to_string(count) + ")");
    return k;
  }

  void changed() { ++version; }

  void measure() {
    if (values_version == version) return;
    const auto start = Clock::now();
    const Eigen::MatrixXd& x = X();
    const int n = num_base();
    at_rest = !drag || x == rest_vertices;
    inverted_by_det = -1;
    if (at_rest) {
      face_values = shown_frame().face_stretch;
    } else {
      const RestTets& tets = drag->rest_tets();
      const Eigen::VectorXd stretch = tet_stretch(tets, x);
      face_values = face_stretch_from_tets(x, tets.T, stretch);
      const Eigen::VectorXd det = tet_deformation_determinants(tets, x);
      inverted_by_det = static_cast<int>((det.array() <= 0).count());
    }
    Shell shell;
    shell.base = x.topRows(n);
    shell.top = x.bottomRows(n);
    shell.F = input.shell.F;
    const double frame_thickness = drag ? 0.0 : shown_frame().thickness;
    shell.thickness = frame_thickness > 0 ? frame_thickness : input.shell.thickness;
    vertex_values = vertex_thickness_ratio(shell);
    values_version = version;
    if (!at_rest) values_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  }

  ojson stretch_summary() const {
    if (values_version != version || face_values.size() == 0) return nullptr;
    double max = 0;
    for (Eigen::Index f = 0; f < face_values.size(); ++f)
      if (std::isfinite(face_values[f])) max = std::max(max, face_values[f]);
    // At rest the input's own stretch: against the ideal prisms for a generated shell, against its
    // rest shell for deform and pose outputs (their shell.vtu stores that).
    const bool deformed = input.made_by == "deform" || input.made_by == "pose";
    return {{"against", !at_rest ? "rest shell" : deformed ? "input rest shell" : "input"},
            {"mean", face_values.mean()},
            {"max", max}};
  }

  ojson stats() const {
    ojson j = message("stats");
    j["phase"] = phase;
    j["vertices"] = 2 * num_base();
    j["tets"] = 3 * input.shell.F.rows();
    if (drag) {
      j["handles"] = drag->handles().handles.size();
      j["handle_vertices"] = drag->handles().constrained_vertices().size();
      if (const int built = drag->solver_levels(); built > 0) j["solver_levels"] = built;
    } else {
      j["frame"] = frame;
    }
    if (last_step) {
      ojson step = last_step->to_json();
      step["seq"] = answered_seq;
      step["latency_ms"] = last_latency_ms;
      j["step"] = step;
    } else {
      j["step"] = nullptr;
    }
    j["stretch"] = stretch_summary();
    j["inverted_tets"] = values_version == version && inverted_by_det >= 0 ? ojson(inverted_by_det) : ojson(nullptr);
    j["validity"] = validity_version == version ? validity : ojson(nullptr);
    j["values_ms"] = values_seconds >= 0 ? ojson(1000 * values_seconds) : ojson(nullptr);
    if (!solver_note.empty()) j["solver"] = solver_note;
    return j;
  }

  void send_positions(const ViewSink& send, float solve_ms, float latency_ms) const {
    if (drag)
      send({encode_view_positions(ViewFrameKind::Positions, answered_seq, solve_ms, latency_ms, X(), origin, unit), true});
    else send({encode_view_positions(ViewFrameKind::Frame, static_cast<std::uint32_t>(frame), 0, 0, X(), origin, unit), true});
  }

  void send_values(const ViewSink& send) {
    measure();
    send({encode_view_values(drag ? answered_seq : static_cast<std::uint32_t>(frame), face_values, vertex_values), true});
  }

  void send_stats(const ViewSink& send) const {
    ViewOutgoing m = text(stats());
    m.snapshot = true;
    send(std::move(m));
  }

  // The handles as the page draws them: centres and translations in page units, like the
  // positions (a saved handle file keeps model coordinates).
  void send_handles(const ViewSink& send) const {
    ojson j = message("handles");
    j["handles"] = drag->handles_json();
    for (ojson& h : j["handles"]["handles"]) {
      if (h.contains("rotate"))
        for (int d = 0; d < 3; ++d)
          h["rotate"]["center"][d] = (h["rotate"]["center"][d].get<double>() - origin[d]) * unit;
      if (h.contains("translate"))
        for (int d = 0; d < 3; ++d) h["translate"][d] = h["translate"][d].get<double>() * unit;
    }
    send(text(j));
  }

  // The whole picture after a jump (undo, reset, frame): positions, colors, statistics.
  void send_state(const ViewSink& send) {
    send_positions(send, 0, 0);
    send_values(send);
    send_stats(send);
  }

  // A group added to a posed shell holds its vertices where they are: its motion becomes the
  // rigid motion that best carries them from rest to their current positions.
  void hold_in_place(int k) {
    const Handle& h = drag->handles().handles[k];
    const Eigen::MatrixXd& x = drag->vertices();
    if (x == rest_vertices) return; // at rest the motion stays exactly none
    Eigen::Vector3d rest_mean = Eigen::Vector3d::Zero(), now_mean = Eigen::Vector3d::Zero();
    for (int v : h.vertices) {
      rest_mean += rest_vertices.row(v).transpose();
      now_mean += x.row(v).transpose();
    }
    rest_mean /= static_cast<double>(h.vertices.size());
    now_mean /= static_cast<double>(h.vertices.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (int v : h.vertices)
      cov += (x.row(v).transpose() - now_mean) * (rest_vertices.row(v).transpose() - rest_mean).transpose();
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
    if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) D(2, 2) = -1;
    const Eigen::Matrix3d R = svd.matrixU() * D * svd.matrixV().transpose();
    const Eigen::AngleAxisd turn(R);
    // x = R (u - c) + c + t with c the group's center: t = now_mean - R (rest_mean - c) - c.
    const Eigen::Vector3d t = now_mean - R * (rest_mean - h.center) - h.center;
    const bool turned = std::abs(turn.angle()) > 1e-12 && turn.axis().allFinite();
    drag->set_motion(k, t, turned ? turn.axis() : Eigen::Vector3d::UnitZ(), turned ? turn.angle() * 180 / M_PI : 0.0);
  }

  // A shell without handle vertices has nothing to settle towards (and its solve would fail with
  // "no handle vertices", shown after the last group was removed as if a drag had gone wrong).
  bool has_handle_vertices() const { return drag && !drag->handles().constrained_vertices().empty(); }

  void handles_edited(const ViewSink& send) {
    handles_changed = true;
    settle_pending = has_handle_vertices();
    send_handles(send);
    send_stats(send);
  }
};

ViewSession::ViewSession(ViewInput input, ViewSessionOptions options) : impl_(std::make_unique<Impl>()) {
  options.check();
  if (input.frames.empty()) throw InputError("view: nothing to show");
  if (!(input.shell.thickness > 0)) throw InputError(with_file(input.name, "the shell needs a positive thickness"));
  Impl& s = *impl_;
  s.rest_vertices = input.shell.vertices();
  s.radius = std::max(bounding_radius(s.rest_vertices), 1e-300);
  s.origin = 0.5 * (s.rest_vertices.colwise().minCoeff() + s.rest_vertices.colwise().maxCoeff());
  if (!s.origin.allFinite()) s.origin.setZero();
  const double diagonal = (s.rest_vertices.colwise().maxCoeff() - s.rest_vertices.colwise().minCoeff()).norm();
  if (diagonal < 1e-6 || diagonal > 1e18) s.unit = detail::power_of_two_unit(diagonal);
  options.limits.vertex_count = static_cast<int>(s.rest_vertices.rows());
  if (input.posable()) {
    s.drag.emplace(input.shell, options.pose, input.surface);
    s.drag->set_names(input.name, "gshell view");
    s.rest_vertices = s.drag->vertices(); // the frame shown is the shell itself
  }
  s.input = std::move(input);
  s.options = std::move(options);
}

ViewSession::~ViewSession() = default;
ViewSession::ViewSession(ViewSession&&) noexcept = default;
ViewSession& ViewSession::operator=(ViewSession&&) noexcept = default;

void ViewSession::set_log(std::function<void(const std::string&)> log) { impl_->log = std::move(log); }
const ViewInput& ViewSession::input() const { return impl_->input; }
const ViewMessageLimits& ViewSession::limits() const { return impl_->options.limits; }
const DragSession* ViewSession::drag_session() const { return impl_->drag ? &*impl_->drag : nullptr; }

void ViewSession::page_left(const ViewSink& send) {
  const Impl& s = *impl_;
  if (s.drag && s.phase == "dragging") s.send_handles(send);
}

void ViewSession::welcome(const ViewSink& send) {
  Impl& s = *impl_;
  const ViewInput& in = s.input;
  ojson hello = message("hello");
  hello["protocol"] = kProtocolVersion;
  hello["name"] = in.name;
  hello["made_by"] = in.made_by;
  hello["kind"] = in.posable() ? "shell" : "sequence";
  hello["posable"] = in.posable();
  hello["vertices"] = in.shell.num_base_vertices();
  hello["faces"] = in.shell.F.rows();
  hello["tets"] = 3 * in.shell.F.rows();
  hello["thickness"] = in.shell.thickness;
  hello["origin"] = {s.origin.x(), s.origin.y(), s.origin.z()};
  hello["unit"] = s.unit;
  ojson frames = ojson::array();
  if (!in.posable())
    for (const ViewFrame& f : in.frames) frames.push_back(fs::path(f.name).filename().string());
  hello["frames"] = frames;
  hello["output_dir"] = fs::absolute(s.options.output_dir).lexically_normal().string();
  hello["max_message_bytes"] = s.options.limits.max_bytes;
  // The solver is built lazily (DragSession), so the levels a small mesh holds may be known only
  // after the first build: `levels` is null until then, and `stats` carries it from there on.
  const int built = s.drag ? s.drag->solver_levels() : 0;
  hello["solver"] = {{"kind", pose_solver_name(s.options.pose.solver)},
                     {"levels_asked", s.options.pose.levels_asked()},
                     {"levels", built > 0 ? ojson(built) : ojson(nullptr)},
                     {"event_iterations", s.options.event_iterations},
                     {"tolerance", s.options.pose.solve.tolerance}};
  ColorScale stretch;
  stretch.max = kDefaultStretchMax;
  ColorScale thickness;
  thickness.ramp = ColorScale::Ramp::BlueGreenRed;
  thickness.min = 1 - kDefaultThicknessSpread;
  thickness.max = 1 + kDefaultThicknessSpread;
  thickness.label = "thickness/eta";
  hello["scales"] = {
      {"stretch", scale_json(stretch, "stretch = sum (sigma_i - 1)^2 per tet; a face shows the volume-weighted mean of "
                                      "its prism's 3 tets")},
      {"thickness", scale_json(thickness, "thickness = length(top_i - base_i) / eta per vertex")}};
  send(text(hello, true));
  send({encode_view_faces(in.shell.F), true, true});
  // The rest of the welcome goes to the new page only as well: the others have it.
  auto to_new_page = [&send](ViewOutgoing out) {
    out.to_sender = true;
    send(std::move(out));
  };
  s.send_positions(to_new_page, 0, 0);
  s.send_values(to_new_page);
  if (s.drag) s.send_handles(to_new_page);
  s.send_stats(to_new_page);
}

void ViewSession::receive(std::string_view bytes, const ViewSink& send, Clock::time_point received) {
  std::string type;
  try {
    const ViewMessage m = parse_view_message(bytes, impl_->options.limits);
    type = view_message_type(m);
    apply(m, send, received);
  } catch (const InputError& e) {
    ojson j = message("error");
    j["request"] = type.empty() ? ojson(nullptr) : ojson(type);
    j["message"] = e.what();
    send(text(j, true));
  } catch (const std::exception& e) { // a bug, not the page's fault: say so, keep serving
    ojson j = message("error");
    j["request"] = type.empty() ? ojson(nullptr) : ojson(type);
    j["message"] = std::string("internal error: ") + e.what();
    send(text(j, true));
  }
}

void ViewSession::load_handles(const std::string& text_, const std::string& name, const ViewSink& send) {
  Impl& s = *impl_;
  DragSession& d = s.posable("load_handles");
  HandleSet h = parse_handles(text_, name, d.rest());
  const bool moves = std::any_of(h.handles.begin(), h.handles.end(),
                                 [](const Handle& g) { return !g.translate.isZero(0) || g.degrees != 0; });
  d.set_handles(std::move(h));
  s.pending = moves; // the motions are solved as a drag event, then settled
  s.received = Clock::now(); // its latency counts from here (from the clock's epoch, it showed the uptime)
  s.handles_edited(send);
  if (s.log) s.log("loaded handles from " + name);
}

void ViewSession::apply(const ViewMessage& m, const ViewSink& send, Clock::time_point received) {
  Impl& s = *impl_;
  const char* type = view_message_type(m);
  if (const auto* add = std::get_if<ViewAddHandle>(&m)) {
    DragSession& d = s.posable(type);
    Handle h;
    h.name = add->name.empty() ? "group " + std::to_string(d.handles().handles.size() + 1) : add->name;
    h.vertices = add->vertices;
    const int k = d.add_handle(std::move(h));
    s.hold_in_place(k);
    s.handles_edited(send);
  } else if (const auto* remove = std::get_if<ViewRemoveHandle>(&m)) {
    s.posable(type).remove_handle(s.group(remove->handle));
    s.handles_edited(send);
  } else if (const auto* set = std::get_if<ViewSetHandleVertices>(&m)) {
    s.posable(type).set_handle_vertices(s.group(set->handle), set->vertices);
    s.hold_in_place(set->handle);
    s.handles_edited(send);
  } else if (const auto* grab = std::get_if<ViewGrab>(&m)) {
    s.posable(type);
    s.group(grab->handle);
    s.drag->checkpoint();
  } else if (const auto* drag = std::get_if<ViewDrag>(&m)) {
    DragSession& d = s.posable(type);
    s.group(drag->handle);
    const Eigen::Vector3d translate = drag->translate / s.unit; // page units -> model units
    // stableNorm: norm() squares first, and [1e300, 0, 0] was "a translation of inf".
    if (translate.stableNorm() > kMaxMotionRadii * s.radius)
      throw InputError("drag: a translation of " + format_number(translate.stableNorm()) +
                       " is more than 1000 times the shell's size");
    d.set_motion(drag->handle, translate, drag->axis, drag->degrees);
    s.pending = true;
    s.seq = drag->seq;
    s.received = received;
    s.phase = "dragging";
  } else if (std::holds_alternative<ViewRelease>(m)) {
    s.posable(type);
    s.settle_requested = true;
    // Every page learns the groups' motions where the drag left them: another page measures its
    // next drag of a group from the motion it holds, and would otherwise pull it back to rest.
    s.send_handles(send);
  } else if (std::holds_alternative<ViewUndo>(m)) {
    if (!s.posable(type).undo()) throw InputError("undo: nothing to undo");
    s.pending = false;
    s.settle_pending = s.has_handle_vertices();
    s.handles_changed = true;
    s.phase = "rest";
    s.changed();
    s.send_handles(send);
    s.send_state(send);
  } else if (std::holds_alternative<ViewReset>(m)) {
    s.posable(type).reset();
    s.pending = false;
    s.settle_pending = false;
    s.phase = "rest";
    s.changed();
    s.send_handles(send);
    s.send_state(send);
  } else if (std::holds_alternative<ViewSaveHandles>(m)) {
    ojson j = message("handles_file");
    j["handles"] = s.posable(type).handles_json();
    send(text(j, true));
  } else if (const auto* load = std::get_if<ViewLoadHandles>(&m)) {
    load_handles(load->text, load->name, send);
  } else if (const auto* save = std::get_if<ViewSaveShell>(&m)) {
    DragSession& d = s.posable(type);
    // Only a shell at rest is certified: during a drag the state is the unguarded preview (a
    // bowl pulled through itself was saved with 16,207 inverted tets under a report of earlier
    // valid steps), during a settle a state the page no longer shows.
    if (s.pending || settle_pending())
      throw InputError("save_shell: the shell is still moving (" + s.phase + "); save it once it has settled");
    const fs::path dir = fs::absolute(fs::path(s.options.output_dir) / save->folder).lexically_normal();
    std::error_code ec;
    if (fs::exists(fs::symlink_status(dir, ec)))
      throw InputError("save_shell: " + dir.string() + " exists (the viewer only writes new folders)");
    d.write(dir.string());
    if (s.log) s.log("wrote " + dir.string() + " (top.obj, base.obj, shell.vtu, report.json)");
    ojson j = message("saved");
    j["what"] = "shell";
    j["path"] = dir.string();
    send(text(j));
  } else if (const auto* show = std::get_if<ViewShowFrame>(&m)) {
    if (s.drag) throw InputError("frame: this input is a single shell, not a sequence");
    if (show->index >= static_cast<int>(s.input.frames.size()))
      throw InputError("frame: no frame " + std::to_string(show->index) + " (there are " +
                       std::to_string(s.input.frames.size()) + ")");
    if (!s.input.frames_held) // read before anything changes: a frame that cannot be read leaves the shown one
      s.read_frame = show->index > 0 ? std::optional(read_view_frame(s.input, show->index)) : std::nullopt;
    s.frame = show->index;
    s.changed();
    s.send_state(send);
  } else if (std::holds_alternative<ViewCertify>(m)) {
    certify(send);
  } // ViewDrawn: flow control, the server's (view_server.cpp)
}

bool ViewSession::drag_pending() const { return impl_->pending; }
bool ViewSession::settle_pending() const { return impl_->drag && (impl_->settle_pending || impl_->settle_requested); }
bool ViewSession::settle_requested() const { return impl_->settle_requested; }

void ViewSession::solve_drag(const ViewSink& send) {
  Impl& s = *impl_;
  if (!s.pending || !s.drag) return;
  s.pending = false;
  PoseStepReport step;
  if (s.options.reduced_events) {
    step = s.drag->preview(1.0, s.options.event_iterations);
  } else {
    SolveOptions limits = s.options.pose.solve;
    limits.max_iterations = s.options.event_iterations;
    step = s.drag->drag(1.0, limits);
  }
  s.handles_changed = false; // the solver is built for them now
  s.solver_note.clear();
  s.last_step = step;
  s.answered_seq = s.seq;
  s.settle_pending = true;
  s.phase = "dragging";
  s.changed();
  s.last_latency_ms = std::chrono::duration<double, std::milli>(Clock::now() - s.received).count();
  s.send_positions(send, static_cast<float>(1000 * step.seconds), static_cast<float>(s.last_latency_ms));
  // Colors only when they cost little next to the solve; big shells get them at rest.
  if (s.values_seconds >= 0 && s.values_seconds <= s.options.values_share * step.seconds) s.send_values(send);
  s.send_stats(send);
}

bool ViewSession::settle(const ViewSink& send, const std::function<bool()>& interrupt, double stream_seconds) {
  Impl& s = *impl_;
  if (!settle_pending()) return true;
  s.settle_requested = false;
  s.phase = "settling";
  s.send_stats(send); // the pages showed "dragging" for the whole settle (95 s on sphere:8)
  SolveOptions limits = s.options.pose.solve;
  auto last_stream = Clock::now();
  limits.progress = [&](int, double, double seconds) {
    if (std::chrono::duration<double>(Clock::now() - last_stream).count() < stream_seconds) return;
    s.send_positions(send, static_cast<float>(1000 * seconds), 0);
    last_stream = Clock::now();
  };
  std::optional<PoseStepReport> step;
  try {
    step = s.drag->settle(limits, interrupt);
  } catch (const InputError&) { // e.g. a part of the shell without a handle: no use retrying
    s.settle_pending = false;
    s.phase = "rest";
    throw;
  }
  s.changed();
  s.handles_changed = false;
  if (!step) {
    s.phase = "interrupted";
    return false;
  }
  s.solver_note.clear();
  s.last_step = step;
  s.settle_pending = false; // converged, or stopped at the iteration limit: either way done
  s.settle_requested = false; // a release answered while it ran asked for this very settle
  s.phase = step->converged ? "settled" : "stopped";
  s.send_positions(send, static_cast<float>(1000 * step->seconds), 0);
  s.send_values(send);
  s.send_stats(send);
  return true;
}

bool ViewSession::prepare() {
  Impl& s = *impl_;
  if (!s.drag || !s.handles_changed) return false;
  s.handles_changed = false;
  if (s.drag->handles().handles.empty()) return false;
  try {
    s.drag->prepare();
    s.solver_note.clear();
  } catch (const InputError& e) {
    s.solver_note = e.what();
  }
  return true;
}

std::optional<ViewSession::CertifyTask> ViewSession::certify_task() const {
  const Impl& s = *impl_;
  if (s.validity_version == s.version) return std::nullopt;
  return CertifyTask{s.version, s.X(), s.input.shell.F};
}

nlohmann::ordered_json ViewSession::run_certify_task(const CertifyTask& task) {
  // The exact certificate (docs/validity.md), base pairs included: a pose moves the base too.
  const Eigen::Index n = task.X.rows() / 2;
  const ShellCertificate c = certify_shell(task.X.topRows(n), task.X.bottomRows(n), task.F);
  nlohmann::ordered_json j = certificate_report(c);
  j["seconds"] = c.seconds;
  return j;
}

bool ViewSession::certified(std::uint64_t version, nlohmann::ordered_json validity, const ViewSink& send) {
  Impl& s = *impl_;
  if (version != s.version) return false;
  s.validity = std::move(validity);
  s.validity_version = version;
  if (s.values_version != s.version) s.send_values(send); // at rest: the colors catch up too
  s.send_stats(send);
  return true;
}

void ViewSession::certify(const ViewSink& send) {
  if (const std::optional<CertifyTask> task = certify_task()) certified(task->version, run_certify_task(*task), send);
  else impl_->send_stats(send);
}

nlohmann::ordered_json ViewSession::stats() const { return impl_->stats(); }

} // namespace gshell
