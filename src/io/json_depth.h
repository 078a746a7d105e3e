#pragma once
// How deeply a JSON text nests, found without parsing it: our readers of JSON files the user
// hands us (reports, handle files, viewer messages) refuse deep nesting before anything recursive
// (nlohmann's dump in an error message, the HTML report's formatting) walks the tree.
#include <string_view>

namespace gshell::io_detail {

/// The largest number of [ and { open at once outside strings; counting stops once it exceeds
/// `stop_above` (the result is then stop_above + 1).
int json_nesting_depth(std::string_view text, int stop_above);

} // namespace gshell::io_detail
