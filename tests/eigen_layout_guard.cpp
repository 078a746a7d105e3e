// Compiled by the test eigen_layout_guard without gshell::gshell's Eigen definitions: the
// compilation must stop at include/gshell/eigen_abi.h's #error (see CMakeLists.txt).
#include <gshell/shell/shell.h>

int main() { return gshell::Shell{}.num_base_vertices(); }
