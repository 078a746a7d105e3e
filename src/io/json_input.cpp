#include "json_input.h"

#include <set>
#include <vector>

namespace gshell::io_detail {

int json_nesting_depth(std::string_view text, int stop_above) {
  int depth = 0, deepest = 0;
  bool in_string = false, escaped = false;
  for (const char c : text) {
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > deepest) deepest = depth;
      if (deepest > stop_above) return deepest;
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return deepest;
}

nlohmann::json parse_json_noting_repeated_keys(std::string_view text, std::string& repeated) {
  using json = nlohmann::json;
  repeated.clear();
  std::vector<std::set<std::string>> keys; // of the objects open at this point
  const json::parser_callback_t note = [&](int, json::parse_event_t event, json& parsed) {
    if (event == json::parse_event_t::object_start) keys.emplace_back();
    if (event == json::parse_event_t::object_end && !keys.empty()) keys.pop_back();
    if (event == json::parse_event_t::key && !keys.empty() && !keys.back().insert(parsed.get<std::string>()).second &&
        repeated.empty())
      repeated = parsed.get<std::string>();
    return true;
  };
  return json::parse(text.begin(), text.end(), note);
}

std::string not_valid_json(const nlohmann::json::exception& e) {
  const std::string what = e.what();
  const std::size_t at = what.find("] ");
  return "not valid JSON (" + (at == std::string::npos ? what : what.substr(at + 2)) + ")";
}

} // namespace gshell::io_detail
