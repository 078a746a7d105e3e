#include <gshell/quality/stretch_report.h>

namespace gshell {

nlohmann::ordered_json stretch_report(const StretchStats& s) {
  return {{"stretch", {{"mean", s.mean}, {"volume_mean", s.volume_mean}, {"max", s.max}, {"p99", s.p99}}},
          {"inverted_tets", s.inverted}};
}

} // namespace gshell
