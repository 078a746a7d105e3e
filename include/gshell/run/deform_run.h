#pragma once
// The deform job (`gshell deform`, Python `gshell.deform`): a generated shell driven by a sequence
// of deformed bases (paper §4.2, first type), the whole frame loop with its per-frame outputs,
// summary and report.
//
// Output folder: report.json (below), frame_NNNN/ per frame (top.obj with the base's faces and
// UVs, shell.vtu with cell data stretch and det_F against the rest shell, detail.obj with --embed),
// optionally preview.png.
#include <gshell/deform/base_frames.h>
#include <gshell/deform/embedding.h>
#include <gshell/deform/shell_deformer.h>
#include <gshell/mesh.h>
#include <gshell/run/shell_folder.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace gshell {

struct DeformRunOptions {
  DeformOptions frame;         ///< per frame: iterations, tolerance, warm start (the defaults are DeformOptions{}'s)
  bool compare_offset = false; ///< also measure re-extruding each frame by the vertex-normal offset

  /// \throws InputError naming the parameter (iterations, tolerance) when it is out of range.
  void check() const;
};

/// Everything a deformation reads, loaded and checked before any work is done.
struct DeformInput {
  std::string shell_name;                 ///< as the report names the rest shell
  Shell shell;                            ///< the rest shell (thickness > 0)
  TriMesh surface;                        ///< its base's faces and UVs (top.obj of each frame gets them)
  std::string rest_warning;               ///< invalid_rest_shell_warning of its report: empty unless it says invalid
  std::vector<std::string> frame_names;   ///< as the report names the frames
  BaseFrames frames;                      ///< n x 3 each (long sequences of large bases read as needed)
  std::string detail_name;                ///< the embedded detail mesh, or empty
  TriMesh detail;
  /// What reading the detail read past (read_mesh's warnings) and the data it holds that the
  /// carried copy does not (normals, colors, materials: carried_data_warning).
  std::vector<std::string> detail_warnings;
};

/// Reads the rest shell folder, every base frame (BaseFrames::load; a folder of frames stands for
/// its frame files, expand_frame_arguments) and the detail mesh (if any).
/// \throws InputError naming the first folder or file that cannot be used.
DeformInput load_deform_input(const std::string& shell_dir, const std::vector<std::string>& frames,
                              const std::string& embed = {});

/// One frame's figures, as `gshell deform` reports it and Python's Deformer.last shows it:
/// {iterations, converged, energy [start, then per iteration], stretch {mean, volume_mean, max,
/// p99} against the rest shell, inverted_tets (against the rest shell), seconds, guard_setup_seconds
/// (building the guard, the first guarded frame: not in seconds), valid, method
/// (unguarded, bounded, guarded, tets_only, failed), substeps, guarded_iterations,
/// thinned_vertices, certificate {inverted_tets, top_self_intersections, top_base_intersections,
/// wall_intersections, nested_parts, exact, seconds}, base_self_intersections (the frame's base against itself),
/// unextrudable_vertices (FrameResult::unextrudable_vertices: why an invalid frame must invert tets)}.
nlohmann::ordered_json frame_json(const FrameResult& frame);

struct DeformFrameRecord {
  int frame = 0;                      ///< 1-based
  std::string base;                   ///< the frame's name
  FrameResult result;                 ///< without the top (written to the folder instead)
  std::optional<StretchStats> offset; ///< compare_offset: stretch of the re-extruded offset shell
  /// The frame's base is the rest base turned inside out (a negative scale: the best linear map
  /// from the rest base to it reverses orientation), so its top lies on the other side (a warning).
  bool mirrored = false;
  /// {frame, base, frame_json..., offset {stretch, inverted_tets}}
  nlohmann::ordered_json to_json() const;
};

struct DeformRun {
  std::string shell;                 ///< the rest shell's name
  int base_vertices = 0, tets = 0;
  double thickness = 0;
  DeformRunOptions options;
  int replaced_rest_tets = 0;        ///< see deformation_rest_tets
  double factor_seconds = 0, setup_seconds = 0;
  struct Embed {
    std::string detail;
    int points = 0, outside = 0;
    double max_outside_distance = 0;
  };
  std::optional<Embed> embed;
  std::vector<DeformFrameRecord> frames;

  /// What a user must hear even with progress off: one line naming the frames that are not valid
  /// and why (the base crosses itself, unextrudable base vertices, unguarded by allow_invalid, or
  /// none of those: the guard could not make them valid), one naming frames whose base has faces
  /// of zero area (their crossings are those faces'), one naming mirrored frames (their tops lie on
  /// the other side of the base: inside a closed one), and one when detail points lie farther
  /// than the thickness outside the shell (they follow their nearest tet's map extrapolated, so
  /// their error grows with that distance); empty when neither holds.
  std::vector<std::string> warnings() const;

  /// report.json: command, shell, base_vertices, tets, thickness, tolerance, max_iterations,
  /// warm_start, allow_invalid, replaced_rest_tets, factor_seconds, setup_seconds, embed {detail,
  /// points, outside, max_outside_distance}, summary {frames, median_seconds, total_seconds,
  /// guard_setup_seconds (kept out of the frames' seconds: FrameResult::guard_setup_seconds),
  /// median_iterations, max_iterations, unconverged_frames, mean_volume_stretch, max_stretch,
  /// inverted_tets, valid_frames, invalid_frames, certificate_inverted_tets, guarded_frames,
  /// max_substeps, offset {...}}, warnings [warnings()], frames [DeformFrameRecord::to_json].
  nlohmann::ordered_json to_json() const;
};

/// Called once after the setup (frames empty) and after every frame.
using DeformProgress = std::function<void(const DeformRun& run, int frame_count)>;

/// Runs the frame loop (ShellDeformer, one factorisation), carrying the detail along. With a
/// non-empty `out`, writes the output folder through a StagedFolder (complete or not at all; an
/// earlier deform output there is replaced, a folder of other files is an error).
/// \throws InputError on bad options or output path.
DeformRun run_deform(const DeformInput& input, const DeformRunOptions& options, const std::string& out = {},
                     const DeformProgress& progress = {}, const BeforeCommit& before_commit = {});

/// A folder holds nothing but a deform output (report.json, preview.png, frame_NNNN/).
bool holds_only_deform_output(const std::filesystem::path& dir);

} // namespace gshell
