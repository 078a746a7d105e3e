// gshell animate: synthetic base frames (a smooth bend or twist) to drive `gshell deform`.
#include "command_registry.h"
#include "parameter_flags.h"
#include "progress.h"
#include "surface_input.h"
#include "warnings.h"

#include <gshell/run/frames.h>
#include <gshell/run/staged_folder.h>
#include <gshell/deform/synthetic_motion.h>
#include <gshell/error.h>
#include <gshell/format_number.h>
#include <gshell/io/write_mesh.h>
#include <gshell/quality/triangle_intersections.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <sstream>

namespace {

namespace fs = std::filesystem;

struct AnimateArgs {
  std::string base;
  double bend = NAN, twist = NAN;
  double band = 1.0;
  int frames = 30;
  std::string axis = "auto"; ///< x, y, z, or auto: the longest bounding-box axis
  std::string out;
};

bool holds_only_frames(const fs::path& dir) {
  for (const auto& entry : fs::directory_iterator(dir))
    if (!gshell::frame_number(entry.path().filename().string(), ".obj")) return false;
  return true;
}

void run_animate(const AnimateArgs& args) {
  if (args.frames < 1) throw gshell::InputError("--frames must be >= 1");
  if (!(args.band > 0 && args.band <= 1)) throw gshell::InputError("--band must be in (0, 1]");
  const bool bending = !std::isnan(args.bend);
  const double degrees = bending ? args.bend : args.twist;
  if (!std::isfinite(degrees)) throw gshell::InputError("the angle must be finite");
  // 100 turns: a bend past one turn already runs the base through itself, and far beyond this the
  // angle's rounding (1e300 degrees is a multiple of 360 to every digit a double keeps) decides
  // the frames.
  constexpr int kMaxDegrees = 100 * 360;
  if (std::abs(degrees) > kMaxDegrees)
    throw gshell::InputError("the angle must be within +-" + std::to_string(kMaxDegrees) + " degrees (100 turns; got " +
                             gshell::format_number(degrees, 10) + ")");
  // Before any frame is made: a folder that cannot be replaced fails at once, not after them all.
  gshell::check_output_folder(args.out, holds_only_frames);
  gshell::TriMesh mesh = gshell::cli::load_surface(args.base, "animate");
  const gshell::MotionFrame frame =
      args.axis == "auto" ? gshell::motion_frame(mesh.V) : gshell::motion_frame(mesh.V, args.axis[0] - 'x');
  const Eigen::MatrixXd rest = mesh.V;

  // A bend or twist far enough makes a base pass through itself (a rotor's blades twisted into
  // each other, a strip bent past a full turn), and no shell is clean where its base crosses
  // itself: the frames are still written, with a warning, so that `gshell deform` reporting them
  // invalid is no surprise. Counted by the certificate's exact test, against the input's own.
  const auto crossings = [&](const Eigen::MatrixXd& V) {
    return static_cast<int>(gshell::surface_self_intersections(V, mesh.F).size());
  };
  const int rest_crossings = crossings(rest);
  int crossing_frames = 0, first_crossing = 0, most_crossings = 0;

  gshell::StagedFolder staged(args.out);
  gshell::cli::Progress progress("animate", 0.2); // throttled: 100,000 quick frames made 24,000 log lines
  for (int k = 1; k <= args.frames; ++k) {
    const double angle = degrees * gshell::ramp(k, args.frames);
    mesh.V = bending ? gshell::bend(rest, frame, angle, args.band) : gshell::twist(rest, frame, angle);
    if (const int c = crossings(mesh.V); c > rest_crossings) {
      if (crossing_frames++ == 0) first_crossing = k;
      most_crossings = std::max(most_crossings, c);
    }
    staged.write([&] { gshell::write_mesh((staged.path() / gshell::frame_name(k, ".obj", args.frames)).string(), mesh); });
    progress.update("frame " + std::to_string(k) + "/" + std::to_string(args.frames));
  }
  staged.commit(holds_only_frames);
  progress.finish_status();
  if (crossing_frames > 0) // a warning even with --quiet, as pose's blocked steps
    gshell::cli::print_warning(
        "animate", std::to_string(crossing_frames) + " of " + std::to_string(args.frames) + " frames (the first " +
                       gshell::frame_name(first_crossing, ".obj", args.frames) + ") make the base cross itself (up to " +
                       std::to_string(most_crossings) + " intersecting face pairs, the input " +
                       std::to_string(rest_crossings) + "); no shell stays clean where its base crosses itself");
  std::ostringstream done;
  done << "wrote " << args.frames << (args.frames == 1 ? " frame" : " frames") << " of a " << (bending ? "bend" : "twist")
       << " to " << degrees << " degrees " << (bending ? "along" : "about") << " the " << "xyz"[frame.long_axis]
       << " axis to " << args.out;
  progress.line(done.str());
}

void add_animate_command(CLI::App& parent) {
  auto args = std::make_shared<AnimateArgs>();
  auto* cmd = parent.add_subcommand(
      "animate", "Write K frames of a smooth bend or twist of a base mesh (input for `gshell deform`)");
  cmd->add_option("base", args->base, "Base mesh (file or builtin:NAME[:RES])")->required();
  auto* bend = cmd->add_option("--bend", args->bend, "Bend the axis (--axis) into an arc of A degrees in total");
  auto* twist = cmd->add_option("--twist", args->twist, "Twist about the axis (--axis) by A degrees end to end");
  cmd->add_option("--axis", args->axis,
                  "Axis to bend or twist: x, y, z, or auto, the longest side of the bounding box (ties: x before y "
                  "before z)")
      ->check(CLI::IsMember({"auto", "x", "y", "z"}))
      ->capture_default_str();
  cmd->add_option("--band", args->band,
                  "With --bend: fraction of the long axis that bends (a fold when < 1), centred")
      ->capture_default_str();
  bend->excludes(twist);
  twist->excludes(bend);
  cmd->add_option("--frames", args->frames, "Number of frames K; frame K reaches the full angle")
      ->capture_default_str();
  cmd->add_option("-o,--output", args->out, "Output folder: frame_0001.obj .. frame_K.obj")->required();
  cmd->callback([args, cmd, bend, twist] {
    if (bend->count() + twist->count() != 1) throw gshell::InputError("give exactly one of --bend A or --twist A");
    gshell::cli::check_applies(*cmd, "--band", bend->count() > 0, "--bend (a twist turns the whole axis)");
    run_animate(*args);
  });
}

const gshell::cli::CommandRegistrar reg{45, add_animate_command};

} // namespace
