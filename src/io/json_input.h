#pragma once
// Checks of JSON the user or a page hands us (reports, handle files, viewer messages) that
// nlohmann's parser leaves to the reader.
#include <nlohmann/json.hpp>

#include <string>
#include <string_view>

namespace gshell::io_detail {

/// How deeply a JSON text nests, found without parsing it, so that deep nesting is refused before
/// anything recursive (nlohmann's dump in an error message, the HTML report's formatting) walks
/// the tree: the largest number of [ and { open at once outside strings; counting stops once it
/// exceeds `stop_above` (the result is then stop_above + 1).
int json_nesting_depth(std::string_view text, int stop_above);

/// json::parse(text), noting in `repeated` the first key given twice in one object ("" when none).
/// JSON leaves repeated keys to the reader and nlohmann keeps the last one, so a second "handles"
/// or "type" would silently replace the first. \throws json::exception as json::parse.
nlohmann::json parse_json_noting_repeated_keys(std::string_view text, std::string& repeated);

/// "not valid JSON (parse error at line L, column C: ...)": a parse error as the user should read
/// it, nlohmann's own text without its "[json.exception...]" prefix.
std::string not_valid_json(const nlohmann::json::exception& e);

} // namespace gshell::io_detail
