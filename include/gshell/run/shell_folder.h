#pragma once
// A shell folder: the one on-disk form of a shell, written by `gshell generate` and `gshell pose`
// (and, per frame, by `gshell deform`), read by deform, pose, texture, render and report.
//
//   base.obj     the base surface (faces, vertex order and UVs of the input)
//   top.obj      the top surface, same faces and vertex order (top vertex i over base vertex i)
//   shell.vtu    all 2n vertices (base rows, then top rows) and the 3m prism tets, with per-tet
//                cell data (always `stretch`; generate adds `inverted` and `prism`, deform and
//                pose `det_F`)
//   report.json  the run's report; `thickness` is eta as a number or as {"eta": ...}
//   preview.png  optional (--render)
//
// A deform output holds frame_NNNN/ folders of top.obj + shell.vtu (+ detail.obj) whose report
// and base are the run's: the frame folder reads like a shell folder (see read_shell_folder).
#include <gshell/mesh.h>
#include <gshell/shell/shell.h>

#include <gshell/eigen_abi.h>
#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace gshell {

/// What a shell folder holds, read back.
struct ShellFolder {
  Shell shell;                    ///< thickness 0 when unknown (only if not required)
  TriMesh surface;                ///< faces (and UVs, when stored) of the base, positions of the base
  std::string made_by;            ///< report.json `method` (generate) or `command` (deform, pose); may be empty
  nlohmann::ordered_json report;  ///< the folder's report.json (a deform frame: its run's); null if none
  Eigen::MatrixXi tets;           ///< shell.vtu's tets (3m x 4), when read
  Eigen::VectorXd tet_stretch;    ///< shell.vtu's `stretch` (3m), when read and present
  TriMesh detail;                 ///< detail.obj (deform --embed), or empty
};

struct ShellFolderReadOptions {
  /// Thickness eta must come from the report (deform and pose need it); otherwise 0 if absent.
  bool require_thickness = true;
  /// Read shell.vtu's tets and stretch too (render); base and top come from shell.vtu anyway when
  /// base.obj is missing.
  bool read_tets = false;
};

/// Reads a shell folder. Base and top come from base.obj + top.obj when both exist (same vertex
/// count and faces required), else from shell.vtu's 2n points, with the faces of top.obj or, when
/// there is none, recovered from the prism tets (3 per face). The report is DIR/report.json or,
/// for a frame_NNNN folder without one, the parent's. Also reads detail.obj when present.
/// \throws InputError naming DIR or the file when DIR is no shell folder, a file cannot be read,
///         the surfaces disagree, or the thickness is required and missing or not positive.
ShellFolder read_shell_folder(const std::string& dir, const ShellFolderReadOptions& options = {});

/// The warning a pose or deformation of the shell in folder `dir` starts with when the folder's
/// report calls it invalid: "DIR: the rest shell is not valid (199 inverted tets, 2335 top/top,
/// 2908 top/base and 0 wall intersecting pairs; its base crosses itself at 1643 face pairs); the
/// guard leaves those places out, so a RESULT may stay invalid there" (`result`: "pose step",
/// "frame"). Empty when the report calls the shell valid or says nothing of its validity
/// (generate's `valid`, `certificate` and `base_self_intersections`).
std::string invalid_rest_shell_warning(const std::string& dir, const nlohmann::ordered_json& report,
                                       const std::string& result);

/// DIR/report.json, parsed with its key order kept.
/// \throws InputError naming the file when it is missing or not a JSON object.
nlohmann::ordered_json read_report(const std::filesystem::path& dir);

/// Writes `report` (pretty-printed) to PATH atomically. \throws InputError when it cannot.
void write_report(const std::filesystem::path& path, const nlohmann::ordered_json& report);

/// A folder holds a shell (top.obj or shell.vtu), as opposed to a sequence of frames.
bool is_shell_folder(const std::filesystem::path& dir);

/// Whether `file` is one a gshell output folder is read from: base.obj, top.obj, shell.vtu,
/// report.json or detail.obj in a shell folder or in a folder with a report.json (a deform
/// output). Only the commands that write such folders write these, and then the whole folder:
/// another output written over one (`gshell report DIR -o DIR/report.json`) breaks the folder.
bool is_output_folder_file(const std::filesystem::path& file);

/// Called with the staging folder, complete, just before it is moved into place: what it writes
/// (e.g. preview.png) arrives together with the rest or not at all.
using BeforeCommit = std::function<void(const std::filesystem::path& staged)>;

/// What write_shell_folder writes.
struct ShellFolderContents {
  TriMesh surface;          ///< the base's faces and UVs (positions are taken from X)
  Eigen::MatrixXd X;        ///< 2n x 3 shell vertices, base rows then top rows
  std::vector<std::pair<std::string, Eigen::MatrixXd>> cell_data; ///< one row per tet (3m)
  nlohmann::ordered_json report;
};

/// Writes base.obj, top.obj, shell.vtu (prism tets of the surface's faces) and report.json into
/// the existing folder `dir` (e.g. a staging folder or a frame folder).
/// \throws InputError naming the file that cannot be written, or when the surface and the shell
///         disagree in shape.
void write_shell_files(const std::filesystem::path& dir, const ShellFolderContents& contents);

/// Writes a whole shell folder DIR through a StagedFolder: complete or not at all. An existing
/// DIR is replaced when it is empty or holds an earlier output of the same command (the report's
/// `command`, "generate" when it names none): a folder of other files, or a shell folder another
/// command made (pose writing over the shell it was posed from), is an error and nothing of it is
/// deleted.
/// \throws InputError on a bad output path or a failed write (nothing is left behind).
void write_shell_folder(const std::string& dir, const ShellFolderContents& contents,
                        const BeforeCommit& before_commit = {});

/// The command that wrote a shell folder's report: its "command" entry (pose), or "generate" for a
/// report without one (generate's).
std::string shell_output_command(const nlohmann::ordered_json& report);

/// A folder holds nothing but the files of a shell folder, and its report.json says `command` made
/// it (the StagedFolder commit rule of write_shell_folder; "generate" or "pose").
bool holds_shell_output_of(const std::filesystem::path& dir, const std::string& command);

} // namespace gshell
