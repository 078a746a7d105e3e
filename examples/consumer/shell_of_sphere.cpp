// Builds the shell of a surface (default: the built-in sphere) with the installed gshell library
// and prints its report.json. Usage: shell_of_sphere [MESH] [THICKNESS_RATIO]
#include <gshell/error.h>
#include <gshell/io/load_mesh.h>
#include <gshell/shell/generate_report.h>
#include <gshell/shell/generate_shell.h>

#include <iostream>
#include <string>

int main(int argc, char** argv) {
  const std::string input = argc > 1 ? argv[1] : "builtin:sphere";
  const double ratio = argc > 2 ? std::stod(argv[2]) : 0.05;
  try {
    const gshell::TriMesh mesh = gshell::load_mesh(input);
    gshell::GenerateOptions options; // the rigid method, the library's defaults
    options.thickness = gshell::thickness_from_ratio(mesh.V, ratio);
    const gshell::GenerateResult result = gshell::generate_shell(mesh.V, mesh.F, options);
    std::cout << gshell::generate_report(result, input, ratio).dump(2) << '\n';
  } catch (const gshell::InputError& e) {
    std::cerr << "shell_of_sphere: " << e.what() << '\n';
    return 1;
  }
}
