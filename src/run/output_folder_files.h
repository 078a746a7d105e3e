#pragma once
// The names of the files gshell writes into its output folders, in one place. What a folder holds
// decides whether a later run may replace it (holds_shell_output_of, holds_only_deform_output, the
// staged folder's message) and which files other commands must not write over
// (is_output_folder_file): a name added to what a command writes belongs here.
#include <string_view>

namespace gshell {

/// The shell: its surfaces, tets and report (generate and pose; each frame folder of deform).
inline constexpr std::string_view kShellFiles[] = {"base.obj", "top.obj", "shell.vtu", "report.json"};
inline constexpr std::string_view kReportFile = "report.json";
/// Beside a shell or a deformation's frames: their picture (--preview).
inline constexpr std::string_view kPreviewFile = "preview.png";
/// In a deformed frame's folder: the embedded detail carried along (deform --embed).
inline constexpr std::string_view kDetailFile = "detail.obj";

/// Whether `name` is one of kShellFiles.
inline bool is_shell_file(std::string_view name) {
  for (const std::string_view f : kShellFiles)
    if (name == f) return true;
  return false;
}

} // namespace gshell
