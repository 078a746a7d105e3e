// Builds the shell of a surface (default: the built-in sphere) with the installed gshell library
// and prints its report.json. Usage: shell_of_sphere [MESH] [THICKNESS_RATIO]
#include <gshell/error.h>
#include <gshell/io/load_mesh.h>
#include <gshell/run/generate_run.h>

#include <iostream>
#include <string>

int main(int argc, char** argv) {
  const std::string input = argc > 1 ? argv[1] : "builtin:sphere";
  try {
    gshell::GenerateRunOptions options; // the library's defaults: the rigid method, 50 iterations, ...
    options.thickness.thickness_ratio = argc > 2 ? std::stod(argv[2]) : 0.05;
    options.check();
    const gshell::GenerateRun run = gshell::run_generate(gshell::load_mesh(input), input, options);
    std::cout << run.to_json().dump(2) << '\n';
  } catch (const gshell::InputError& e) {
    std::cerr << "shell_of_sphere: " << e.what() << '\n';
    return 1;
  }
}
