#pragma once
// `--thickness T | --thickness-ratio R`, for the commands that build or judge a shell.
#include <gshell/run/generate_run.h>

#include <CLI/CLI.hpp>

namespace gshell::cli {

inline void add_thickness_flags(CLI::App& cmd, ThicknessChoice& thickness) {
  cmd.add_option("--thickness", thickness.thickness, "Shell thickness eta in model units");
  cmd.add_option("--thickness-ratio", thickness.thickness_ratio,
                 "Shell thickness as a ratio of the bounding sphere's radius (centre = bounding-box centre, "
                 "radius = farthest vertex; e.g. 0.01)");
}

} // namespace gshell::cli
