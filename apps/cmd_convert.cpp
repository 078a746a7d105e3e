// `gshell convert IN OUT`: any readable surface (or builtin:...) to OBJ, OFF or PLY, keeping
// the vertex order and, for OBJ to OBJ, the texture coordinates; `--weld` joins the surface's cuts.
#include "command_registry.h"
#include "parameter_flags.h"
#include "output_file.h"
#include "progress.h"
#include "warnings.h"

#include <gshell/geometry/validate_mesh.h>
#include <gshell/geometry/weld_vertices.h>
#include <gshell/io/load_mesh.h>
#include <gshell/io/write_mesh.h>
#include <gshell/word_list.h>

#include <memory>

namespace {

struct ConvertOptions {
  std::string input, output;
  bool ascii = false, weld = false;
};

void add_convert_command(CLI::App& app) {
  auto opt = std::make_shared<ConvertOptions>();
  CLI::App* cmd = app.add_subcommand(
      "convert", "Convert a surface mesh between formats (read: .obj .off .ply .stl or builtin:NAME; "
                 "write: .obj .off .ply). Vertex order is kept; the input is validated first. Positions, "
                 "faces (polygons split into triangles) and, OBJ to OBJ, texture coordinates are kept; "
                 "colors, normals and other properties are not (a warning names those the input held).");
  cmd->add_option("input", opt->input, "Input mesh file or builtin:NAME[:RES]")->required();
  cmd->add_option("output", opt->output, "Output mesh file (.obj, .off or .ply)")->required();
  cmd->add_flag("--ascii", opt->ascii, "Write PLY as ASCII instead of binary little endian");
  cmd->add_flag("--weld", opt->weld,
                "Join the surface's cuts: boundary vertices at exactly the position of another boundary vertex "
                "(a triangle soup, split seams) become one; the other vertices keep their order");
  cmd->callback([opt, cmd] {
    using namespace gshell;
    cli::check_applies(*cmd, "--ascii", cli::lower_extension(opt->output) == ".ply", "a .ply output");
    // Over its own input is allowed (the file is written whole, then renamed), not over a shell's.
    cli::check_output_file(opt->output, "", {});
    check_mesh_output_format(opt->output); // before the input's warnings: one error line
    std::vector<std::string> warnings, skipped;
    TriMesh mesh = load_mesh(opt->input, opt->weld ? nullptr : &warnings, &skipped);
    cli::Progress progress("convert");
    if (opt->weld) {
      int merged = 0;
      mesh = weld_boundary_vertices(mesh, &merged);
      warnings = require_valid_mesh(mesh, opt->input + " after --weld");
      progress.line("welded " + std::to_string(merged) + " vertices");
    }
    // Only OBJ holds them: said, not silently dropped.
    if (std::string w = dropped_texture_coordinates_warning(opt->input, mesh, opt->output); !w.empty())
      warnings.push_back(std::move(w));
    // What no TriMesh holds is lost whatever the output: said too.
    if (!skipped.empty())
      warnings.push_back(opt->input + ": its " + word_list(skipped) + " are not written to " + opt->output +
                         " (convert keeps positions, faces and, OBJ to OBJ, texture coordinates)");
    cli::print_warnings("convert", warnings);
    write_mesh(opt->output, mesh, {}, opt->ascii);
    progress.line("wrote " + opt->output + " (" + std::to_string(mesh.num_vertices()) + " vertices, " +
                  std::to_string(mesh.num_faces()) + " faces)");
  });
}

const gshell::cli::CommandRegistrar reg{20, add_convert_command};

} // namespace
