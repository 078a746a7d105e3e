// `gshell convert IN OUT`: any readable surface (or builtin:...) to OBJ, OFF or PLY, keeping
// the vertex order and, for OBJ to OBJ, the texture coordinates.
#include "command_registry.h"
#include "progress.h"

#include <gshell/io/load_mesh.h>
#include <gshell/io/write_mesh.h>

#include <iostream>
#include <memory>

namespace {

struct ConvertOptions {
  std::string input, output;
  bool ascii = false;
};

void add_convert_command(CLI::App& app) {
  auto opt = std::make_shared<ConvertOptions>();
  CLI::App* cmd = app.add_subcommand(
      "convert", "Convert a surface mesh between formats (read: .obj .off .ply .stl or builtin:NAME; "
                 "write: .obj .off .ply). Vertex order is kept; the input is validated first.");
  cmd->add_option("input", opt->input, "Input mesh file or builtin:NAME[:RES]")->required();
  cmd->add_option("output", opt->output, "Output mesh file (.obj, .off or .ply)")->required();
  cmd->add_flag("--ascii", opt->ascii, "Write PLY as ASCII instead of binary little endian");
  cmd->callback([opt] {
    const gshell::TriMesh mesh = gshell::load_mesh(opt->input);
    gshell::write_mesh(opt->output, mesh, {}, opt->ascii);
    gshell::cli::Progress("convert").line("wrote " + opt->output + " (" + std::to_string(mesh.num_vertices()) +
                                         " vertices, " + std::to_string(mesh.num_faces()) + " faces)");
  });
}

const gshell::cli::CommandRegistrar reg{20, add_convert_command};

} // namespace
