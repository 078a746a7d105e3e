// `gshell render`: headless PNG renders of shells and surfaces, side by side.
#include "command_registry.h"
#include "output_file.h"
#include "parameter_flags.h"
#include "progress.h"
#include "warnings.h"

#include <gshell/error.h>
#include <gshell/render/image.h>
#include <gshell/render/shell_render.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <regex>

namespace gshell::cli {
namespace {

struct RenderArgs {
  std::vector<std::string> inputs;
  std::string output;
  std::string color = "auto";
  std::string style = "translucent";
  std::string view = "iso";
  std::string size = "1280x720";
  std::vector<std::string> captions;
  std::string max = "default";
  bool ortho = false;
  bool frame_each = false;
  int supersample = 2;
};

void parse_size(const std::string& text, int& width, int& height) {
  std::smatch match;
  static const std::regex pattern(R"((\d+)[xX](\d+))");
  if (!std::regex_match(text, match, pattern)) throw InputError("--size " + text + ": expected WIDTHxHEIGHT, e.g. 1280x720");
  // More than 5 digits is out of range however many there are (and would overflow stoi).
  const auto number = [](const std::string& digits) { return digits.size() > 5 ? 100000 : std::stoi(digits); };
  width = number(match[1]);
  height = number(match[2]);
  if (width < 32 || height < 32 || width > kMaxFigureSide || height > kMaxFigureSide)
    throw InputError("--size " + text + ": width and height must be in [32, " + std::to_string(kMaxFigureSide) + "]");
}

void run_render(const CLI::App& cmd, const RenderArgs& args) {
  ShellRenderOptions options;
  // The image is always PNG: another extension would give a file whose name lies about it.
  check_output_file(args.output, ".png", args.inputs);
  // Options this run would ignore are mistakes to be told of, as in generate and pose.
  check_applies(cmd, "--frame-each", args.inputs.size() > 1, "two or more inputs (panels)");
  parse_size(args.size, options.figure.width, options.figure.height);
  check_flags(cmd, [&] { options.figure.view = parse_view(args.view); });
  options.figure.projection = args.ortho ? Projection::Orthographic : Projection::Perspective;
  options.figure.supersample = args.supersample;
  options.figure.shared_camera = !args.frame_each;
  if (args.max == "auto") {
    options.auto_max = true;
  } else if (args.max != "default") {
    std::size_t used = 0;
    double value = 0;
    try {
      value = std::stod(args.max, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != args.max.size() || !(value > 0) || !std::isfinite(value))
      throw InputError("--max " + args.max + ": expected a positive number or auto");
    options.color_max = value;
  }
  const std::map<std::string, ColorBy> colors{{"auto", ColorBy::Auto}, {"stretch", ColorBy::Stretch},
                                              {"thickness", ColorBy::Thickness}, {"none", ColorBy::None}};
  const std::map<std::string, ShellStyle> styles{{"translucent", ShellStyle::Translucent}, {"cut", ShellStyle::Cut},
                                                 {"base", ShellStyle::Base}, {"top", ShellStyle::Top}};
  options.color_by = colors.at(args.color);
  options.style = styles.at(args.style);

  std::vector<RenderSubject> subjects;
  for (const auto& input : args.inputs) {
    subjects.push_back(load_render_subject(input));
    print_warnings("render", subjects.back().warnings);
  }
  const bool any_shell = std::any_of(subjects.begin(), subjects.end(), [](const RenderSubject& s) { return s.is_shell(); });
  check_applies(cmd, "--max", args.color != "none" && (args.color != "auto" || any_shell),
                "colored renders (--color none colors nothing, --color auto no plain surface)");
  const Image image = render_subjects(subjects, args.captions, options);
  write_png(args.output, image);
  Progress("render").line("wrote " + args.output + " (" + std::to_string(image.width) + "x" +
                          std::to_string(image.height) + ")");
}

void add_render_command(CLI::App& parent) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* cmd = parent.add_subcommand(
      "render", "Render shells or surfaces to a PNG (headless): INPUT is a shell folder from generate/deform/pose, "
                "a mesh file or a builtin:NAME spec; several inputs are drawn side by side");
  cmd->add_option("inputs", args->inputs, "Shell folders, mesh files or builtin specs")->required();
  cmd->add_option("-o,--output", args->output, "Output PNG")->required();
  cmd->add_option("--color", args->color,
                  "Color by per-prism stretch (green 0 .. red at --max), thickness/eta per vertex, or none; "
                  "auto = stretch when the input has it")
      ->check(CLI::IsMember({"auto", "stretch", "thickness", "none"}))
      ->capture_default_str();
  cmd->add_option("--style", args->style,
                  "translucent: opaque base under a see-through top; cut: the half nearer the eye cut away; "
                  "base / top: one surface only")
      ->check(CLI::IsMember({"translucent", "cut", "base", "top"}))
      ->capture_default_str();
  cmd->add_option("--view", args->view, "front|back|left|right|top|bottom|iso or AZIMUTH,ELEVATION in degrees (y up)")
      ->capture_default_str();
  cmd->add_option("--size", args->size, "Image size WIDTHxHEIGHT (all panels together)")->capture_default_str();
  cmd->add_option("--caption", args->captions, "Panel caption, once per input (default: input name and method)");
  cmd->add_option("--max", args->max,
                  "Value drawn red: stretch (default 0.1), or the largest |thickness/eta - 1| (default 0.5); "
                  "auto = the smallest 99th percentile of the panels, rounded up")
      ->capture_default_str();
  cmd->add_flag("--ortho", args->ortho, "Orthographic instead of perspective projection");
  cmd->add_flag("--frame-each", args->frame_each,
                "Frame every panel on its own (default: one camera for all panels, same scale)");
  cmd->add_option("--supersample", args->supersample, "Anti-aliasing: render K times larger and filter down")
      ->check(CLI::Range(1, 4))
      ->capture_default_str();
  cmd->callback([args, cmd] { run_render(*cmd, *args); });
}

const CommandRegistrar reg{80, add_render_command};

} // namespace
} // namespace gshell::cli
