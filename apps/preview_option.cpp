#include "preview_option.h"

#include "parameter_flags.h"

#include <gshell/error.h>
#include <gshell/render/scene.h>
#include <gshell/render/shell_render.h>

namespace gshell::cli {

void require_renderer() {
  if (!offscreen_rendering_available())
    throw InputError("--render: no OSMesa (gshell was built without it, or libOSMesa.so.8 cannot be loaded: "
                     "install libosmesa6)");
}

void add_preview_flags(CLI::App& cmd, bool& render, std::string& view, const std::string& what) {
  CLI::Option* flag = cmd.add_flag("--render", render, "Also write OUT/preview.png: " + what);
  cmd.add_option("--view", view, "Preview direction: front|back|left|right|top|bottom|iso or AZIMUTH,ELEVATION (y up)")
      ->needs(flag)
      ->capture_default_str();
}

ViewDirection check_preview_flags(const CLI::App& cmd, bool render, const std::string& view) {
  ViewDirection direction;
  check_flags(cmd, [&] { direction = parse_view(view); });
  if (render) require_renderer();
  return direction;
}

BeforeCommit preview_writer(bool render, const std::string& output, const ViewDirection& view) {
  if (!render) return {};
  return [output, view](const std::filesystem::path& staged) { render_shell_preview(staged.string(), output, view); };
}

} // namespace gshell::cli
