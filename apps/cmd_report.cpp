// `gshell report`: a self-contained HTML page about a generate / deform / pose output folder.
#include "command_registry.h"
#include "output_file.h"
#include "warnings.h"

#include <gshell/render/html_report.h>

#include <iostream>
#include <memory>

namespace gshell::cli {
namespace {

struct ReportArgs {
  std::string dir, output;
  bool no_renders = false;
};

void add_report_command(CLI::App& parent) {
  auto args = std::make_shared<ReportArgs>();
  CLI::App* cmd = parent.add_subcommand(
      "report", "Write one self-contained HTML page (images inlined) with the settings, figures, plots and renders "
                "of a generate / deform / pose output folder");
  cmd->add_option("dir", args->dir, "Output folder holding report.json")->required();
  cmd->add_option("-o,--output", args->output, "HTML file to write")->required();
  cmd->add_flag("--no-renders", args->no_renders, "Leave out the renders (faster; no OSMesa needed)");
  cmd->callback([args] {
    check_output_file(args->output, ".html", {args->dir});
    ReportOptions options;
    options.renders = !args->no_renders;
    std::vector<std::string> left_out;
    write_html_report(args->dir, args->output, options, &left_out);
    print_warnings("report", left_out);
    std::cout << args->output << "\n"; // scripts print where the page is
  });
}

const CommandRegistrar reg{90, add_report_command};

} // namespace
} // namespace gshell::cli
