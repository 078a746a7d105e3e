// The viewer's session logic without a browser (view/view_session.h): a drag scripted as page
// messages ends where `gshell pose` ends with the same handle targets; bad messages get one error
// each and change nothing; drags coalesce; undo, reset, saving and sequences do what the page
// promises.
#include "shell_fixtures.h"
#include "test_support.h"

#include <gshell/deform/handles.h>
#include <gshell/error.h>
#include <gshell/geometry/builtin_mesh.h>
#include <gshell/io/write_mesh.h>
#include <gshell/run/shell_folder.h>
#include <gshell/view/view_input.h>
#include <gshell/view/view_session.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>

using namespace gshell;
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

/// What the session sent, in order.
struct Outbox {
  std::vector<ViewOutgoing> sent;
  ViewSink sink() {
    return [this](ViewOutgoing m) { sent.push_back(std::move(m)); };
  }
  std::vector<json> messages(const std::string& type) const {
    std::vector<json> out;
    for (const ViewOutgoing& m : sent)
      if (!m.binary) {
        json j = json::parse(m.bytes);
        if (j["type"] == type) out.push_back(j);
      }
    return out;
  }
  std::vector<std::string> frames(ViewFrameKind kind) const {
    std::vector<std::string> out;
    for (const ViewOutgoing& m : sent) {
      std::uint32_t k = 0;
      if (m.binary && m.bytes.size() >= kViewFrameHeaderBytes) std::memcpy(&k, m.bytes.data(), 4);
      if (m.binary && k == static_cast<std::uint32_t>(kind)) out.push_back(m.bytes);
    }
    return out;
  }
  void clear() { sent.clear(); }
};

std::uint32_t frame_seq(const std::string& frame) {
  std::uint32_t seq;
  std::memcpy(&seq, frame.data() + 4, 4);
  return seq;
}

/// hello's "origin": what the page's positions and handle centres are relative to.
Eigen::RowVector3d origin_of(const json& hello) {
  return Eigen::RowVector3d(hello["origin"][0].get<double>(), hello["origin"][1].get<double>(),
                            hello["origin"][2].get<double>());
}

/// The float32 positions of a Positions or Frame frame plus the session's origin, as a 2n x 3
/// matrix in model coordinates.
Eigen::MatrixXd frame_positions(const std::string& frame, const Eigen::RowVector3d& origin) {
  const std::size_t count = (frame.size() - kViewFrameHeaderBytes) / 4;
  Eigen::MatrixXd X(count / 3, 3);
  for (std::size_t i = 0; i < count; ++i) {
    float f;
    std::memcpy(&f, frame.data() + kViewFrameHeaderBytes + 4 * i, 4);
    X(i / 3, i % 3) = f;
  }
  return X.rowwise() + origin;
}

double max_distance(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) { return (a - b).rowwise().norm().maxCoeff(); }

/// A generated flat plate shell (builtin:plane:10, 2 x 2, thickness 0.1) in a folder.
struct PlateFolder {
  test::TempDir tmp{"gshell-view"};
  std::string dir = tmp.file("plate");
  PlateFolder() {
    const test::CliResult r = test::run_cli("generate builtin:plane:10 --thickness 0.1 -q -o '" + dir + "'");
    if (r.exit_code != 0) throw std::runtime_error("generate failed: " + r.err);
  }
};

/// The folder of `gshell generate` on `mesh` (written to NAME.obj in tmp) at `thickness`.
std::string generated_folder(const test::TempDir& tmp, const std::string& name, const TriMesh& mesh,
                             const std::string& thickness) {
  write_mesh(tmp.file(name + ".obj"), mesh);
  const std::string dir = tmp.file(name);
  const test::CliResult r =
      test::run_cli("generate '" + tmp.file(name + ".obj") + "' --thickness " + thickness + " -q -o '" + dir + "'");
  if (r.exit_code != 0) throw std::runtime_error("generate failed: " + r.err);
  return dir;
}

/// Shell vertex ids (both surfaces) whose rest x lies beyond `x` on the side `sign` points to.
std::string ends(const Shell& shell, double x, double sign) {
  const Eigen::MatrixXd X = shell.vertices();
  json ids = json::array();
  for (int v = 0; v < X.rows(); ++v)
    if (sign * (X(v, 0) - x) > 0) ids.push_back(v);
  return ids.dump();
}

ViewSessionOptions tight_options(const std::string& output_dir) {
  ViewSessionOptions o;
  o.pose.hierarchy.levels = 3;
  o.pose.solve.tolerance = 1e-10;
  o.pose.solve.max_iterations = 20000;
  o.output_dir = output_dir;
  return o;
}

std::string drag_message(int seq, int handle, const Eigen::Vector3d& t, double degrees) {
  return json{{"type", "drag"}, {"seq", seq}, {"handle", handle}, {"translate", {t.x(), t.y(), t.z()}},
              {"axis", {0, 1, 0}}, {"degrees", degrees}}
      .dump();
}

/// hold (-x end) and pull (+x end) groups made by page messages.
void add_plate_groups(ViewSession& session, const Shell& shell, Outbox& out) {
  session.receive(R"({"type":"add_handle","name":"hold","vertices":)" + ends(shell, -0.75, -1) + "}", out.sink());
  session.receive(R"({"type":"add_handle","name":"pull","vertices":)" + ends(shell, 0.75, 1) + "}", out.sink());
  ASSERT_TRUE(out.messages("error").empty()) << out.messages("error")[0].dump();
}

bool never() { return false; }

// A drag of the pull group (grab, one drag event, its solve), made after add_plate_groups.
void drag_the_pull_group(ViewSession& session, Outbox& out) {
  session.receive(R"({"type":"grab","handle":1})", out.sink());
  session.receive(drag_message(1, 1, Eigen::Vector3d(0.1, 0, 0.3), -20), out.sink());
  session.solve_drag(out.sink());
}

// `out` holds one "handles" message, for every page, with drag_the_pull_group's motion of the pull
// group in page units.
void expect_the_pull_groups_motion_for_every_page(const Outbox& out) {
  ASSERT_EQ(out.messages("handles").size(), 1u);
  for (const ViewOutgoing& m : out.sent)
    if (!m.binary && json::parse(m.bytes)["type"] == "handles") EXPECT_FALSE(m.to_sender);
  const json pull = out.messages("handles")[0]["handles"]["handles"][1];
  ASSERT_TRUE(pull.contains("translate") && pull.contains("rotate")) << pull.dump();
  EXPECT_NEAR(pull["translate"][0].get<double>(), 0.1, 1e-12); // page units, as the drag's
  EXPECT_NEAR(pull["translate"][2].get<double>(), 0.3, 1e-12);
  EXPECT_NEAR(pull["rotate"]["degrees"].get<double>(), -20, 1e-12);
}

} // namespace

TEST(ViewSession, AReleaseTellsEveryPageWhereTheDragLeftTheGroups) {
  // A second page drags a group from the motion it holds: it must learn the first page's drag,
  // or its first nudge would send the group back towards rest.
  const PlateFolder plate;
  ViewSession session(load_view_input({plate.dir}), tight_options(plate.tmp.path().string()));
  Outbox out;
  session.welcome(out.sink());
  add_plate_groups(session, session.input().shell, out);
  out.clear();
  drag_the_pull_group(session, out);
  EXPECT_TRUE(out.messages("handles").empty()); // not at every drag event: the file lists every vertex
  session.receive(R"({"type":"release"})", out.sink());
  expect_the_pull_groups_motion_for_every_page(out);
}

TEST(ViewSession, APageLeavingMidDragTellsTheOthersWhereItLeftTheGroups) {
  // The dragging page's tab closed before its release: the others hear of the groups' motions
  // then, or their next nudge would pull the group back to rest.
  const PlateFolder plate;
  ViewSession session(load_view_input({plate.dir}), tight_options(plate.tmp.path().string()));
  Outbox out;
  session.welcome(out.sink());
  add_plate_groups(session, session.input().shell, out);
  out.clear();
  session.page_left(out.sink()); // nothing dragged: nothing to tell
  EXPECT_TRUE(out.messages("handles").empty());
  drag_the_pull_group(session, out);
  out.clear();
  session.page_left(out.sink());
  expect_the_pull_groups_motion_for_every_page(out);
}

TEST(ViewSession, ScriptedDragEndsWhereGshellPoseEnds) {
  const PlateFolder plate;
  ViewSession session(load_view_input({plate.dir}), tight_options(plate.tmp.path().string()));
  const Shell& rest = session.input().shell;
  Outbox out;
  session.welcome(out.sink());
  ASSERT_EQ(out.messages("hello").size(), 1u);
  EXPECT_EQ(out.messages("hello")[0]["kind"], "shell");
  ASSERT_EQ(out.frames(ViewFrameKind::Faces).size(), 1u);
  ASSERT_EQ(out.frames(ViewFrameKind::Positions).size(), 1u);
  const Eigen::RowVector3d origin = origin_of(out.messages("hello")[0]);
  EXPECT_LT(max_distance(frame_positions(out.frames(ViewFrameKind::Positions)[0], origin), rest.vertices()), 1e-6);
  add_plate_groups(session, rest, out);

  // A mouse drag: grab, 12 moves (each answered after one iteration), release, rest.
  const Eigen::Vector3d lift(0, 0, 0.6);
  const int events = 12;
  session.receive(R"({"type":"grab","handle":1})", out.sink());
  for (int e = 1; e <= events; ++e) {
    out.clear();
    const double t = static_cast<double>(e) / events;
    session.receive(drag_message(100 + e, 1, t * lift, -30 * t), out.sink());
    EXPECT_TRUE(session.drag_pending());
    session.solve_drag(out.sink());
    const std::vector<std::string> answers = out.frames(ViewFrameKind::Positions);
    ASSERT_EQ(answers.size(), 1u);
    EXPECT_EQ(frame_seq(answers[0]), static_cast<std::uint32_t>(100 + e));
    EXPECT_LE(out.messages("stats")[0]["step"]["iterations"].get<int>(), 1);
  }
  // Mid-drag the state is the unguarded preview, not a certified shell: saving it is refused, and
  // so during the settle (its state is not what the page shows), and nothing is written.
  for (const bool released : {false, true}) {
    if (released) session.receive(R"({"type":"release"})", out.sink());
    out.clear();
    session.receive(R"({"type":"save_shell","folder":"mid"})", out.sink());
    ASSERT_EQ(out.messages("error").size(), 1u) << released;
    EXPECT_EQ(out.messages("error")[0]["message"].get<std::string>().rfind("save_shell: the shell is still moving (", 0), 0u)
        << out.messages("error")[0].dump();
    EXPECT_FALSE(fs::exists(plate.tmp.file("mid")));
  }
  EXPECT_TRUE(session.settle_requested());
  out.clear();
  ASSERT_TRUE(session.settle(out.sink(), never));
  EXPECT_EQ(out.messages("stats").back()["phase"], "settled");
  const Eigen::MatrixXd settled = session.drag_session()->vertices();
  // The page's copy is the server's state (to float32 rounding).
  EXPECT_LT(max_distance(frame_positions(out.frames(ViewFrameKind::Positions).back(), origin), settled), 1e-6);

  // Save the handles and the posed shell as the page's buttons do.
  out.clear();
  session.receive(R"({"type":"save_handles"})", out.sink());
  ASSERT_EQ(out.messages("handles_file").size(), 1u);
  const std::string handles = plate.tmp.file("handles.json");
  test::write_text(handles, out.messages("handles_file")[0]["handles"].dump(2));
  session.receive(R"({"type":"save_shell","folder":"posed"})", out.sink());
  ASSERT_EQ(out.messages("saved").size(), 1u) << (out.messages("error").empty() ? "" : out.messages("error")[0].dump());

  // gshell pose with these handle targets, in as many steps.
  const std::string posed = plate.tmp.file("pose-cli");
  const test::CliResult r = test::run_cli("pose -q --shell '" + plate.dir + "' --handles '" + handles +
                                          "' --levels 3 --tolerance 1e-10 --iterations 20000 --steps 12 -o '" + posed + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const ShellFolder cli = read_shell_folder(posed);
  const ShellFolder mine = read_shell_folder(plate.tmp.file("posed"));
  // The plate is 2 wide and 0.1 thick; both ran to a relative energy change of 1e-10.
  EXPECT_LT(max_distance(cli.shell.vertices(), settled), 1e-5);
  EXPECT_LT(max_distance(mine.shell.vertices(), settled), 1e-9); // the folder holds the session's state
  EXPECT_GT(max_distance(settled, rest.vertices()), 0.3);         // and the drag did move the plate
  EXPECT_EQ(mine.report["command"], "pose");
  EXPECT_NEAR(mine.report["stretch"]["volume_mean"].get<double>(), cli.report["stretch"]["volume_mean"].get<double>(),
              1e-6 * cli.report["stretch"]["volume_mean"].get<double>());
}

TEST(ViewSession, AShellFarFromTheOriginReachesThePageWithItsDetail) {
  // A scan in survey coordinates: float32 positions of their own would sit on a grid of 0.25-0.5
  // units there; relative to hello's origin they keep the shell to float precision of its size.
  test::TempDir tmp{"gshell-view"};
  TriMesh plate = make_plane(10);
  const Eigen::RowVector3d far(5e5, 4e6, 120);
  plate.V.rowwise() += far;
  const std::string dir = generated_folder(tmp, "far", plate, "0.1");
  ViewSession session(load_view_input({dir}), tight_options(tmp.path().string()));
  const Shell& rest = session.input().shell;
  Outbox out;
  session.welcome(out.sink());
  const Eigen::RowVector3d origin = origin_of(out.messages("hello")[0]);
  EXPECT_LT((origin - far).norm(), 2.0);
  ASSERT_EQ(out.frames(ViewFrameKind::Positions).size(), 1u);
  EXPECT_LT(max_distance(frame_positions(out.frames(ViewFrameKind::Positions)[0], origin), rest.vertices()), 1e-6);
  // Handle centres are drawn in the same frame: the group's rest centroid, relative to the origin.
  out.clear();
  session.receive(R"({"type":"add_handle","name":"corner","vertices":[0,1,2]})", out.sink());
  ASSERT_EQ(out.messages("handles").size(), 1u);
  const json centre = out.messages("handles")[0]["handles"]["handles"][0]["rotate"]["center"];
  const Eigen::RowVector3d drawn(centre[0].get<double>(), centre[1].get<double>(), centre[2].get<double>());
  const Eigen::MatrixXd X = rest.vertices();
  EXPECT_LT((drawn + origin - (X.row(0) + X.row(1) + X.row(2)) / 3).norm(), 1e-6);
  EXPECT_LT(drawn.norm(), 2.0);
}

TEST(ViewSession, AHugeShellReachesThePageInUnitsFloat32Holds) {
  // Coordinates up to 1e50 are accepted; float32 ends at 3.4e38. The page gets positions, handle
  // centres and translations in page units, (x - origin) * unit, and its drags come back divided
  // by unit. An ordinary shell keeps unit 1 (the other tests read positions with it).
  test::TempDir tmp{"gshell-view"};
  const double size = 1e45;
  TriMesh plate = make_plane(10);
  plate.V *= size;
  const std::string dir = generated_folder(tmp, "huge", plate, "1e44");
  ViewSession session(load_view_input({dir}), tight_options(tmp.path().string()));
  const Shell& rest = session.input().shell;
  Outbox out;
  session.welcome(out.sink());
  const json hello = out.messages("hello").at(0);
  ASSERT_TRUE(hello.contains("unit")) << hello.dump();
  const double unit = hello["unit"].get<double>();
  int exponent = 0;
  EXPECT_EQ(std::frexp(unit, &exponent), 0.5); // a power of two
  const Eigen::RowVector3d origin = origin_of(hello);
  ASSERT_EQ(out.frames(ViewFrameKind::Positions).size(), 1u);
  const Eigen::MatrixXd page = frame_positions(out.frames(ViewFrameKind::Positions)[0], Eigen::RowVector3d::Zero());
  ASSERT_TRUE(page.allFinite());
  EXPECT_LT(page.cwiseAbs().maxCoeff(), 2.0);
  EXPECT_LT(max_distance((page / unit).rowwise() + origin, rest.vertices()), 1e-6 * size);
  EXPECT_NEAR(hello["thickness"].get<double>(), 1e44, 1e30); // model units; the page multiplies

  session.receive(R"({"type":"add_handle","name":"hold","vertices":)" + ends(rest, -0.75 * size, -1) + "}", out.sink());
  session.receive(R"({"type":"add_handle","name":"pull","vertices":)" + ends(rest, 0.75 * size, 1) + "}", out.sink());
  out.clear();
  const Eigen::Vector3d lift(0, 0, 0.3); // page units
  session.receive(drag_message(1, 1, lift, 0), out.sink());
  ASSERT_TRUE(out.messages("error").empty()) << out.messages("error")[0].dump();
  session.solve_drag(out.sink());
  const Handle& pulled = session.drag_session()->handles().handles.at(1);
  EXPECT_LT((pulled.translate - lift / unit).norm(), 1e-12 * size);
  // The handles message draws that translation and the centre in page units again.
  session.receive(R"({"type":"add_handle","name":"corner","vertices":[60,61,62]})", out.sink());
  ASSERT_TRUE(out.messages("error").empty()) << out.messages("error")[0].dump();
  const json drawn = out.messages("handles").back()["handles"]["handles"];
  ASSERT_EQ(drawn.size(), 3u) << drawn.dump();
  ASSERT_TRUE(drawn[1].contains("translate")) << drawn.dump();
  EXPECT_NEAR(drawn[1]["translate"][2].get<double>(), 0.3, 1e-12);
  const Eigen::MatrixXd X = rest.vertices();
  const Eigen::RowVector3d corner((X.row(60) + X.row(61) + X.row(62)) / 3);
  const json centre = drawn[2]["rotate"]["center"];
  EXPECT_LT((Eigen::RowVector3d(centre[0].get<double>(), centre[1].get<double>(), centre[2].get<double>()) / unit +
             origin - corner).norm(),
            1e-9 * size);
}

TEST(ViewSession, HelloAndStatsTellTheLevelsBuiltNotOnlyThoseAsked) {
  const PlateFolder plate; // 121 base vertices: far fewer levels than asked for below
  ViewSessionOptions options = tight_options(plate.tmp.path().string());
  options.pose.hierarchy.levels = 40;
  ViewSession session(load_view_input({plate.dir}), options);
  Outbox out;
  session.welcome(out.sink());
  const json hello = out.messages("hello").at(0);
  EXPECT_EQ(hello["solver"]["levels_asked"], 40);
  EXPECT_TRUE(hello["solver"]["levels"].is_null()); // no handles yet, so no solver
  add_plate_groups(session, session.input().shell, out);
  session.receive(drag_message(1, 1, Eigen::Vector3d(0, 0, 0.3), 0), out.sink());
  session.solve_drag(out.sink());
  const json stats = out.messages("stats").back();
  const int built = session.drag_session()->solver_levels();
  EXPECT_GE(built, 2);
  EXPECT_LT(built, 40);
  EXPECT_EQ(stats["solver_levels"], built);
  out.clear();
  session.welcome(out.sink()); // a page joining now hears the levels built
  EXPECT_EQ(out.messages("hello").at(0)["solver"]["levels"], built);
}

TEST(ViewSession, BadMessagesGetAnErrorAndChangeNothing) {
  const PlateFolder plate;
  ViewSession session(load_view_input({plate.dir}), tight_options(plate.tmp.path().string()));
  const Shell& rest = session.input().shell;
  const int count = 2 * rest.num_base_vertices();
  Outbox out;
  add_plate_groups(session, rest, out);
  session.receive(drag_message(1, 1, Eigen::Vector3d(0, 0, 0.3), 0), out.sink());
  session.solve_drag(out.sink());
  ASSERT_TRUE(session.settle(out.sink(), never));
  const Eigen::MatrixXd state = session.drag_session()->vertices();
  const HandleSet handles = session.drag_session()->handles();
  fs::create_directory(plate.tmp.path() / "taken");

  const std::vector<std::string> bad = {
      "",
      "{\"type\":\"drag\"",                                                      // cut off
      std::string("\x89PNG\r\n\x1a\n\0\0", 10),                                   // binary
      R"({"type":"drag","seq":2,"handle":1,"translate":[NaN,0,0]})",              // NaN
      R"({"type":"drag","seq":2,"handle":1,"translate":[1e400,0,0]})",            // overflow
      R"({"type":"drag","seq":2,"handle":7,"translate":[0,0,1]})",                // no such group
      R"({"type":"drag","seq":2,"handle":1,"translate":[1e9,0,0]})",              // absurdly far
      R"({"type":"add_handle","vertices":[)" + std::to_string(count) + "]}",     // id out of range
      R"({"type":"add_handle","vertices":[0,1,2]})",                              // already in "hold"
      R"({"type":"remove_handle","handle":5})",
      R"({"type":"frame","index":0})",                                            // not a sequence
      R"({"type":"save_shell","folder":"../escape"})",                            // a path
      R"({"type":"save_shell","folder":"taken"})",                                // exists
      R"({"type":"load_handles","name":"x.json","text":"{\"handles\":[]}"})",     // no handle
      R"({"type":"load_handles","text":"not json"})",
      R"({"type":"teleport"})",
      std::string(session.limits().max_bytes + 1, ' '),                           // oversized
      std::string(50000, '[') + std::string(50000, ']'),                          // deep
  };
  for (const std::string& message : bad) {
    out.clear();
    session.receive(message, out.sink());
    ASSERT_EQ(out.sent.size(), 1u) << message.substr(0, 80);
    const std::vector<json> errors = out.messages("error");
    ASSERT_EQ(errors.size(), 1u) << message.substr(0, 80);
    EXPECT_TRUE(out.sent[0].to_sender);
    EXPECT_FALSE(errors[0]["message"].get<std::string>().empty());
    EXPECT_EQ(errors[0]["message"].get<std::string>().find('\n'), std::string::npos); // one line
    EXPECT_FALSE(session.drag_pending()) << message.substr(0, 80);
  }
  EXPECT_EQ(session.drag_session()->vertices(), state);
  EXPECT_EQ(session.drag_session()->handles(), handles);
  EXPECT_FALSE(fs::exists(plate.tmp.path() / "escape"));
  EXPECT_EQ(test::count_entries(plate.tmp.path() / "taken"), 0);

  // And it keeps working.
  out.clear();
  session.receive(drag_message(3, 1, Eigen::Vector3d(0, 0, 0.5), 0), out.sink());
  session.solve_drag(out.sink());
  ASSERT_TRUE(session.settle(out.sink(), never));
  EXPECT_TRUE(out.messages("error").empty());
  EXPECT_GT(max_distance(session.drag_session()->vertices(), state), 0.1);
}

TEST(ViewSession, DragsArrivingDuringASolveCoalesceIntoTheLatest) {
  const PlateFolder plate;
  ViewSession session(load_view_input({plate.dir}), tight_options(plate.tmp.path().string()));
  Outbox out;
  add_plate_groups(session, session.input().shell, out);
  out.clear();
  for (int e = 1; e <= 5; ++e) session.receive(drag_message(e, 1, Eigen::Vector3d(0, 0, 0.1 * e), 0), out.sink());
  EXPECT_TRUE(out.sent.empty()); // drags are answered by the solve, not one by one
  session.solve_drag(out.sink());
  ASSERT_EQ(out.frames(ViewFrameKind::Positions).size(), 1u);
  EXPECT_EQ(frame_seq(out.frames(ViewFrameKind::Positions)[0]), 5u);
  EXPECT_EQ(session.drag_session()->handles().handles[1].translate, Eigen::Vector3d(0, 0, 0.5));
  EXPECT_FALSE(session.drag_pending());
  out.clear();
  session.solve_drag(out.sink()); // nothing pending: nothing sent
  EXPECT_TRUE(out.sent.empty());
}

TEST(ViewSession, UndoResetAndGroupsOnAPosedShell) {
  const PlateFolder plate;
  ViewSession session(load_view_input({plate.dir}), tight_options(plate.tmp.path().string()));
  const Shell& rest = session.input().shell;
  Outbox out;
  add_plate_groups(session, rest, out);
  session.receive(R"({"type":"grab","handle":1})", out.sink());
  session.receive(drag_message(1, 1, Eigen::Vector3d(0, 0, 0.4), 0), out.sink());
  session.solve_drag(out.sink());
  ASSERT_TRUE(session.settle(out.sink(), never));
  const Eigen::MatrixXd posed = session.drag_session()->vertices();

  // A group added on the posed shell holds its vertices where they are now: settling moves little.
  const Eigen::MatrixXd X = rest.vertices();
  json middle = json::array();
  for (int v = 0; v < X.rows(); ++v)
    if (std::abs(X(v, 0)) < 0.1) middle.push_back(v);
  out.clear();
  session.receive(R"({"type":"add_handle","name":"middle","vertices":)" + middle.dump() + "}", out.sink());
  ASSERT_TRUE(out.messages("error").empty()) << out.messages("error")[0].dump();
  ASSERT_EQ(out.messages("handles").size(), 1u);
  EXPECT_EQ(out.messages("handles")[0]["handles"]["handles"].size(), 3u);
  ASSERT_TRUE(session.settle(out.sink(), never));
  EXPECT_LT(max_distance(session.drag_session()->vertices(), posed), 0.02);

  // Undo the new group, then the drag.
  out.clear();
  session.receive(R"({"type":"undo"})", out.sink());
  EXPECT_EQ(session.drag_session()->handles().handles.size(), 2u);
  EXPECT_EQ(session.drag_session()->vertices(), posed);
  EXPECT_EQ(out.frames(ViewFrameKind::Positions).size(), 1u); // the pages see it at once
  session.receive(R"({"type":"undo"})", out.sink());
  EXPECT_EQ(session.drag_session()->vertices(), rest.vertices()); // before the grab
  // Reset: at rest, groups kept, motions cleared; the colors are the input's stored stretch again.
  session.receive(drag_message(2, 1, Eigen::Vector3d(0.2, 0, 0.2), 10), out.sink());
  session.solve_drag(out.sink());
  out.clear();
  session.receive(R"({"type":"reset"})", out.sink());
  EXPECT_EQ(session.drag_session()->vertices(), rest.vertices());
  EXPECT_TRUE(session.drag_session()->handles().handles[1].translate.isZero(0));
  EXPECT_EQ(out.messages("stats").back()["stretch"]["against"], "input");
  // Nothing left to undo before the first group? Undo until the session says so.
  int undos = 0;
  for (; undos < 50; ++undos) {
    out.clear();
    session.receive(R"({"type":"undo"})", out.sink());
    if (!out.messages("error").empty()) break;
  }
  EXPECT_LT(undos, 50);
  EXPECT_TRUE(session.drag_session()->handles().handles.empty());
}

TEST(ViewSession, ValidityAndColorsFollowTheShell) {
  const PlateFolder plate;
  // The drag below must be able to break validity (pose steps are guarded by default).
  ViewSessionOptions options = tight_options(plate.tmp.path().string());
  options.pose.allow_invalid = true;
  ViewSession session(load_view_input({plate.dir}), options);
  Outbox out;
  session.welcome(out.sink());
  const json hello = out.messages("hello")[0];
  EXPECT_EQ(hello["scales"]["stretch"]["max"], 0.1); // gshell render's scale
  EXPECT_EQ(hello["scales"]["stretch"]["ramp"].size(), 65u * 3);
  ASSERT_EQ(out.frames(ViewFrameKind::Values).size(), 1u);
  const std::string values = out.frames(ViewFrameKind::Values)[0];
  const std::size_t m = session.input().shell.F.rows(), n = session.input().shell.num_base_vertices();
  EXPECT_EQ(values.size(), kViewFrameHeaderBytes + 4 * (m + n));
  // A flat plate generated by the rigid method is its own ideal: stretch ~0, thickness 1.
  float first_thickness;
  std::memcpy(&first_thickness, values.data() + kViewFrameHeaderBytes + 4 * m, 4);
  EXPECT_NEAR(first_thickness, 1.0f, 1e-5f);

  ASSERT_TRUE(session.certify_task().has_value());
  out.clear();
  session.certify(out.sink());
  json stats = out.messages("stats").back();
  // The shell certificate's report (certificate_report): exact counts, base pairs tested.
  EXPECT_EQ(stats["validity"]["valid"], true);
  EXPECT_EQ(stats["validity"]["certificate"]["inverted_tets"], 0);
  EXPECT_EQ(stats["validity"]["certificate"]["top_base_intersections"], 0);
  EXPECT_EQ(stats["validity"]["base_self_intersections"], 0);
  EXPECT_FALSE(session.certify_task().has_value());

  // Fold the plate onto itself: +x end carried over to the -x end, upside down.
  add_plate_groups(session, session.input().shell, out);
  out.clear();
  const std::optional<ViewSession::CertifyTask> stale = [&] {
    session.receive(drag_message(1, 1, Eigen::Vector3d(-1.75, 0, 0.05), 180), out.sink());
    session.solve_drag(out.sink());
    return session.certify_task();
  }();
  ASSERT_TRUE(stale.has_value());
  session.receive(drag_message(2, 1, Eigen::Vector3d(-1.75, 0, 0.02), 180), out.sink());
  session.solve_drag(out.sink());
  // A result for an older state is dropped: the shell moved meanwhile.
  EXPECT_FALSE(session.certified(stale->version, ViewSession::run_certify_task(*stale), out.sink()));
  out.clear();
  session.certify(out.sink());
  stats = out.messages("stats").back();
  // Folded onto itself the layer crosses itself: the certificate says so.
  EXPECT_EQ(stats["validity"]["valid"], false);
  EXPECT_GT(stats["validity"]["certificate"]["top_base_intersections"].get<int>() +
                stats["validity"]["certificate"]["wall_intersections"].get<int>(),
            0);
  EXPECT_EQ(stats["stretch"]["against"], "rest shell");
  EXPECT_GT(stats["stretch"]["max"].get<double>(), 0.01);
}

TEST(ViewSession, SequencesShowFramesAndCannotBePosed) {
  const PlateFolder plate;
  // Two frames: the plate, and the plate posed (a pose folder is a shell folder too).
  const std::string handles = plate.tmp.file("lift.json");
  test::write_text(handles, R"({"handles":[{"select":{"box":[-2,-2,-1,-0.75,2,1]}},
                              {"select":{"box":[0.75,-2,-1,2,2,1]},"translate":[0,0,0.5]}]})");
  const std::string posed = plate.tmp.file("lifted");
  ASSERT_EQ(test::run_cli("pose -q --shell '" + plate.dir + "' --handles '" + handles + "' -o '" + posed + "'").exit_code, 0);
  ViewSession session(load_view_input({plate.dir, posed}), tight_options(plate.tmp.path().string()));
  EXPECT_EQ(session.drag_session(), nullptr);
  Outbox out;
  session.welcome(out.sink());
  EXPECT_EQ(out.messages("hello")[0]["kind"], "sequence");
  EXPECT_EQ(out.messages("hello")[0]["frames"].size(), 2u);
  ASSERT_EQ(out.frames(ViewFrameKind::Frame).size(), 1u);
  const Eigen::RowVector3d origin = origin_of(out.messages("hello")[0]);
  out.clear();
  session.receive(R"({"type":"frame","index":1})", out.sink());
  ASSERT_EQ(out.frames(ViewFrameKind::Frame).size(), 1u);
  EXPECT_EQ(frame_seq(out.frames(ViewFrameKind::Frame)[0]), 1u);
  EXPECT_LT(max_distance(frame_positions(out.frames(ViewFrameKind::Frame)[0], origin), read_shell_folder(posed).shell.vertices()),
            1e-6);
  for (const char* m : {R"({"type":"add_handle","vertices":[0]})", R"({"type":"undo"})", R"({"type":"frame","index":2})"}) {
    out.clear();
    session.receive(m, out.sink());
    EXPECT_EQ(out.messages("error").size(), 1u) << m;
  }
  // Frames of different shells do not make a sequence.
  const std::string other = plate.tmp.file("other");
  ASSERT_EQ(test::run_cli("generate builtin:plane:8 --thickness 0.1 -q -o '" + other + "'").exit_code, 0);
  EXPECT_THROW(load_view_input({plate.dir, other}), InputError);
  EXPECT_THROW(load_view_input({plate.tmp.file("missing")}), InputError);
}

// Shell folders of different thickness compared as frames (two generate outputs): each frame's
// thickness colors are against its own eta, not the first frame's.
TEST(ViewSession, FramesOfDifferentThicknessAreColoredAgainstTheirOwn) {
  const PlateFolder plate; // thickness 0.1
  const std::string thick = plate.tmp.file("thick");
  ASSERT_EQ(test::run_cli("generate builtin:plane:10 --thickness 0.25 -q -o '" + thick + "'").exit_code, 0);
  ViewSession session(load_view_input({plate.dir, thick}), tight_options(plate.tmp.path().string()));
  Outbox out;
  session.welcome(out.sink());
  session.receive(R"({"type":"frame","index":1})", out.sink());
  const std::vector<std::string> values = out.frames(ViewFrameKind::Values);
  ASSERT_EQ(values.size(), 2u);
  const std::size_t m = session.input().shell.F.rows(), n = session.input().shell.num_base_vertices();
  for (const std::string& frame : values) {
    ASSERT_EQ(frame.size(), kViewFrameHeaderBytes + 4 * (m + n));
    double mean = 0;
    for (std::size_t v = 0; v < n; ++v) {
      float t;
      std::memcpy(&t, frame.data() + kViewFrameHeaderBytes + 4 * (m + v), 4);
      mean += t / static_cast<double>(n);
    }
    EXPECT_NEAR(mean, 1.0, 1e-3); // a flat plate's rigid shell is its eta thick (frame 1 was 2.5)
  }
}

// A sequence too large to hold (here: any, with a budget of one byte) keeps only its first frame
// and reads the others when shown: the page gets the same positions and colors as from a held
// sequence, and a frame that turns out not to belong is an error that leaves the shown one.
TEST(ViewSession, ASequenceTooLargeToHoldShowsWhatAHeldOneShows) {
  const PlateFolder plate;
  const std::string handles = plate.tmp.file("lift.json");
  test::write_text(handles, R"({"handles":[{"select":{"box":[-2,-2,-1,-0.75,2,1]}},
                              {"select":{"box":[0.75,-2,-1,2,2,1]},"translate":[0,0,0.5]}]})");
  const std::string posed = plate.tmp.file("lifted"), other = plate.tmp.file("other");
  ASSERT_EQ(test::run_cli("pose -q --shell '" + plate.dir + "' --handles '" + handles + "' -o '" + posed + "'").exit_code, 0);
  ASSERT_EQ(test::run_cli("generate builtin:plane:8 --thickness 0.1 -q -o '" + other + "'").exit_code, 0);
  // The plate with its faces listed in reverse: as many vertices and faces, other tets.
  TriMesh reversed = make_plane(10);
  reversed.F = reversed.F.colwise().reverse().eval();
  const std::string reordered = plate.tmp.file("reordered");
  write_mesh(plate.tmp.file("reordered.obj"), reversed);
  ASSERT_EQ(test::run_cli("generate '" + plate.tmp.file("reordered.obj") + "' --thickness 0.1 -q -o '" + reordered + "'").exit_code,
            0);
  const std::vector<std::string> dirs{plate.dir, posed, plate.dir, other, reordered};
  ViewInputOptions small;
  small.held_frame_bytes = 1;
  const ViewInput read_when_shown = load_view_input(dirs, small);
  EXPECT_FALSE(read_when_shown.frames_held);
  ASSERT_EQ(read_when_shown.frames.size(), 5u);
  EXPECT_EQ(read_when_shown.frames[1].X.size(), 0); // not read yet
  EXPECT_THROW(load_view_input(dirs), InputError);  // held: every frame is checked up front

  // The frames the page gets (positions and colors) for 1, 0, 2, 1 and then 3 and 4, from a
  // session holding the three good frames and from one reading all five when shown.
  auto shown = [&](ViewInput input, Outbox& out) {
    ViewSession session(std::move(input), tight_options(plate.tmp.path().string()));
    session.welcome(out.sink());
    for (int k : {1, 0, 2, 1, 3, 4}) session.receive(R"({"type":"frame","index":)" + std::to_string(k) + "}", out.sink());
    return out.frames(ViewFrameKind::Frame).size();
  };
  Outbox held_out, read_out;
  const std::size_t held_frames = shown(load_view_input({plate.dir, posed, plate.dir}), held_out);
  const std::size_t read_frames = shown(read_when_shown, read_out);
  EXPECT_EQ(held_frames, 5u);
  EXPECT_EQ(read_frames, 5u); // frames 3 and 4 sent nothing
  EXPECT_EQ(held_out.frames(ViewFrameKind::Frame), read_out.frames(ViewFrameKind::Frame));
  EXPECT_EQ(held_out.frames(ViewFrameKind::Values), read_out.frames(ViewFrameKind::Values));
  EXPECT_NE(read_out.frames(ViewFrameKind::Frame)[1], read_out.frames(ViewFrameKind::Frame)[2]); // 1 is posed
  ASSERT_EQ(held_out.messages("error").size(), 2u); // no frames 3 and 4
  ASSERT_EQ(read_out.messages("error").size(), 2u); // frames 3 and 4 are other shells
  EXPECT_NE(read_out.messages("error")[0]["message"].get<std::string>().find("other"), std::string::npos)
      << read_out.messages("error")[0].dump();
  EXPECT_NE(read_out.messages("error")[1]["message"].get<std::string>().find("reordered"), std::string::npos)
      << read_out.messages("error")[1].dump();
}

// A surface input is generated as `gshell generate` would, and carries what generate warns of
// (here the cut of a triangle soup, first); a shell folder carries none.
TEST(ViewSession, ASurfaceInputCarriesWhatGenerateWarnsOf) {
  test::TempDir dir("view-soup");
  write_mesh(dir.file("soup.obj"), test::triangle_soup(make_sphere(1)));
  const ViewInput soup = load_view_input({dir.file("soup.obj")});
  ASSERT_FALSE(soup.warnings.empty());
  EXPECT_EQ(soup.warnings.front().rfind(dir.file("soup.obj") + ": vertices ", 0), 0u) << soup.warnings.front();
  EXPECT_TRUE(load_view_input({"builtin:sphere:1"}).warnings.empty());
  const PlateFolder plate;
  EXPECT_TRUE(load_view_input({plate.dir}).warnings.empty());
}

TEST(ViewSession, AShellFolderItsReportCallsInvalidCarriesAWarning) {
  const PlateFolder plate;
  json report = json::parse(test::read_text(plate.dir + "/report.json"));
  report["valid"] = false;
  report["certificate"]["inverted_tets"] = 7;
  test::write_text(plate.dir + "/report.json", report.dump());
  const ViewInput in = load_view_input({plate.dir});
  ASSERT_EQ(in.warnings.size(), 1u);
  EXPECT_EQ(in.warnings[0].rfind(plate.dir + ": the rest shell is not valid (7 inverted tets, 0 top/top, 0 top/base and 0 "
                                 "wall intersecting pairs); ", 0), 0u) << in.warnings[0];
}

TEST(ViewSession, RemovingEveryGroupLeavesNothingToSettle) {
  // With no handle vertex left there is nothing to solve towards: the settle that followed failed
  // with "no handle vertices", shown on the page as a drag's error.
  const PlateFolder plate;
  ViewSession session(load_view_input({plate.dir}), tight_options(plate.tmp.path().string()));
  Outbox out;
  session.welcome(out.sink());
  session.receive(R"({"type":"add_handle","name":"a","vertices":[1]})", out.sink());
  EXPECT_TRUE(session.settle_pending());
  for (const char* last : {R"({"type":"remove_handle","handle":0})", R"({"type":"undo"})"}) {
    if (std::string(last).find("undo") != std::string::npos) {
      session.receive(R"({"type":"add_handle","name":"a","vertices":[1]})", out.sink());
      ASSERT_TRUE(session.settle(out.sink(), never));
    }
    out.clear();
    session.receive(last, out.sink());
    EXPECT_TRUE(out.messages("error").empty()) << out.messages("error")[0].dump();
    EXPECT_FALSE(session.settle_pending()) << last;
  }
}

TEST(ViewSession, AThicknessForShellFoldersIsAnErrorNotIgnored) {
  // A shell folder keeps the thickness it was made with; `view SHELL --thickness 0.3` used to show
  // the folder's 0.1 shell as if asked for nothing.
  const PlateFolder plate;
  ViewInputOptions options;
  options.generate.thickness.thickness = 0.3;
  for (const std::vector<std::string>& inputs : {std::vector<std::string>{plate.dir}, {plate.dir, plate.dir}}) {
    try {
      load_view_input(inputs, options);
      ADD_FAILURE() << "no error for " << inputs.size() << " input(s)";
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()), plate.dir + ": a thickness applies only to a surface input (a shell folder keeps its own)");
    }
  }
  // Without one the folder loads with its own thickness; a surface takes the one given.
  EXPECT_NEAR(load_view_input({plate.dir}).shell.thickness, 0.1, 1e-12);
  EXPECT_DOUBLE_EQ(load_view_input({"builtin:plane:4"}, options).shell.thickness, 0.3);
}

TEST(ViewSession, LoadedHandlesAreSolvedLikeADrag) {
  const PlateFolder plate;
  ViewSession session(load_view_input({plate.dir}), tight_options(plate.tmp.path().string()));
  Outbox out;
  const std::string text = R"({"handles":[{"name":"hold","select":{"box":[-2,-2,-1,-0.75,2,1]}},
                              {"name":"pull","select":{"box":[0.75,-2,-1,2,2,1]},"translate":[0,0,0.5]}]})";
  session.load_handles(text, "lift.json", out.sink());
  EXPECT_TRUE(session.drag_pending());
  EXPECT_EQ(out.messages("handles")[0]["handles"]["handles"][1]["name"], "pull");
  session.solve_drag(out.sink());
  ASSERT_TRUE(session.settle(out.sink(), never));
  // The pulled end sits on its target.
  const DragSession& d = *session.drag_session();
  const std::vector<int> ids = d.handles().handles[1].vertices;
  const Eigen::MatrixXd X = session.input().shell.vertices();
  for (int v : ids) EXPECT_NEAR(d.vertices()(v, 2) - X(v, 2), 0.5, 1e-12);
  EXPECT_THROW(session.load_handles("{", "broken.json", out.sink()), InputError);
}

TEST(ViewSession, TheStoredStretchIsNamedByWhatTheInputMeasuredItAgainst) {
  // A generated shell stores its stretch against the ideal prisms, deform and pose outputs against
  // their rest shell: the page was told "ideal prisms" for all three.
  const PlateFolder plate;
  for (const auto& [made_by, against] : std::vector<std::pair<std::string, std::string>>{
           {"rigid", "input"}, {"deform", "input rest shell"}, {"pose", "input rest shell"}}) {
    ViewInput input = load_view_input({plate.dir});
    input.made_by = made_by;
    ViewSession session(std::move(input), tight_options(plate.tmp.path().string()));
    Outbox out;
    session.welcome(out.sink());
    ASSERT_FALSE(out.messages("stats").empty());
    EXPECT_EQ(out.messages("stats").back()["stretch"]["against"], against) << made_by;
  }
}

TEST(ViewSession, PagesHearThatTheShellIsSettling) {
  // The pages kept showing "dragging" for the whole settle (95 s on sphere:8): its start is said.
  const PlateFolder plate;
  ViewSession session(load_view_input({plate.dir}), tight_options(plate.tmp.path().string()));
  Outbox out;
  add_plate_groups(session, session.input().shell, out);
  session.receive(drag_message(1, 1, Eigen::Vector3d(0, 0, 0.3), 0), out.sink());
  session.solve_drag(out.sink());
  out.clear();
  ASSERT_TRUE(session.settle(out.sink(), never));
  const auto stats = out.messages("stats");
  ASSERT_GE(stats.size(), 2u);
  EXPECT_EQ(stats.front()["phase"], "settling");
  EXPECT_EQ(stats.back()["phase"], "settled");
}
