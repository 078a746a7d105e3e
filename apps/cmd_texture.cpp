// gshell texture: geometric texture through the shell map (paper Fig. 5).
#include "command_registry.h"
#include "output_file.h"
#include "progress.h"
#include "warnings.h"

#include <gshell/deform/geometric_texture.h>
#include <gshell/error.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/load_mesh.h>
#include <gshell/io/read_mesh.h>
#include <gshell/io/write_mesh.h>
#include <gshell/run/shell_folder.h>

#include <memory>
#include <sstream>
#include <vector>

namespace {

struct TextureArgs {
  std::string shell;
  std::string tile;
  std::vector<int> repeat{1, 1};
  std::string out;
};

void run_texture(const TextureArgs& args) {
  if (args.repeat.size() != 2 || args.repeat[0] < 1 || args.repeat[1] < 1)
    throw gshell::InputError("--repeat needs two counts >= 1");
  gshell::cli::check_output_file(args.out, "", {args.shell, args.tile});
  gshell::check_mesh_output_format(args.out); // before the work
  const gshell::ShellFolder folder = gshell::read_shell_folder(args.shell);
  const gshell::Shell& shell = folder.shell;
  const gshell::TriMesh& uv_source = folder.surface;
  if (!uv_source.has_uv())
    throw gshell::InputError(gshell::with_file(args.shell, "base.obj has no texture coordinates (vt)"));
  std::vector<std::string> tile_warnings, skipped;
  const gshell::TriMesh tile = gshell::is_builtin_tile(args.tile)
                                   ? gshell::make_builtin_tile(args.tile)
                                   : gshell::read_mesh(args.tile, &tile_warnings, &skipped);
  if (tile.num_vertices() == 0 || tile.num_faces() == 0)
    throw gshell::InputError(gshell::with_file(args.tile, "the tile has no faces"));
  gshell::require_usable_coordinates(tile.V, args.tile);
  gshell::require_usable_texture_coordinates(tile, args.tile);
  if (!skipped.empty()) tile_warnings.push_back(gshell::carried_data_warning(args.tile, skipped, args.out));
  // Each copy carries the tile's texture coordinates.
  if (std::string w = gshell::dropped_texture_coordinates_warning(args.tile, tile, args.out); !w.empty())
    tile_warnings.push_back(std::move(w));
  gshell::cli::print_warnings("texture", tile_warnings);
  // What is left to go wrong is the base's UV layout (every UV triangle degenerate) or the number
  // of tiles over it: named by the shell folder, the input that holds the layout.
  gshell::GeometricTexture texture;
  try {
    texture = gshell::map_geometric_texture(shell, uv_source, tile, args.repeat[0], args.repeat[1]);
  } catch (const gshell::InputError& e) {
    throw gshell::InputError(gshell::with_file(args.shell, e.what()));
  }
  gshell::write_mesh(args.out, texture.mesh);
  gshell::cli::Progress progress("texture");
  if (progress.enabled()) {
    std::ostringstream line;
    line << args.repeat[0] << " x " << args.repeat[1] << " tiles, " << texture.mesh.num_vertices() << " vertices ("
         << texture.joined << " joined where tiles meet), " << texture.mesh.num_faces() << " faces over UV ["
         << texture.uv_min.x() << ", " << texture.uv_max.x() << "] x [" << texture.uv_min.y() << ", "
         << texture.uv_max.y() << "]";
    if (texture.reversed_faces > 0)
      line << "; " << texture.reversed_faces
           << " faces over mirrored UV islands wound the other way round, to face as in the tile";
    if (texture.outside > 0)
      line << "; " << texture.outside << " vertices outside the UV prisms (extrapolated, up to "
                << texture.max_outside_distance << " in texture space)";
    line << "; wrote " << args.out;
    progress.line(line.str());
  }
}

void add_texture_command(CLI::App& parent) {
  auto args = std::make_shared<TextureArgs>();
  auto* cmd = parent.add_subcommand(
      "texture", "Map a geometric texture tile (x, y = UV in [0,1], z = height in [0,1]) into a shell");
  cmd->add_option("--shell", args->shell, "Shell folder written by `gshell generate` (its base.obj needs vt)")
      ->required();
  cmd->add_option("--tile", args->tile, "Tile mesh in texture space, or builtin:bumps[:N]")->required();
  cmd->add_option("--repeat", args->repeat, "Tiles along U and V over the base's UV rectangle")
      ->expected(2)
      ->capture_default_str();
  cmd->add_option("-o,--output", args->out, "Output mesh (.obj, .off, .ply)")->required();
  cmd->callback([args] { run_texture(*args); });
}

const gshell::cli::CommandRegistrar reg{55, add_texture_command};

} // namespace
