#include "invalid_items_warning.h"

#include <gshell/quality/certificate_report.h>

namespace gshell::detail {

std::string named_items(const std::string& noun, const std::vector<int>& ids) {
  return noun + (ids.size() == 1 ? " " : "s ") + first_ids(ids);
}

std::string unconverged_items_warning(const std::string& noun, const std::vector<int>& ids, int max_iterations,
                                      const std::string& consequence) {
  // With no iterations asked for (deform's --iterations 0: each frame is its warm start) none ran out.
  if (ids.empty() || max_iterations == 0) return {};
  return named_items(noun, ids) + " ran out of iterations before converging (--iterations " +
         std::to_string(max_iterations) + "): " + consequence;
}

std::string invalid_items_warning(const InvalidItems& items, int total, const std::string& noun, bool unguarded) {
  if (items.all.empty()) return {};
  const auto named = [&](const std::vector<int>& ids) { return named_items(noun, ids); };
  std::vector<std::string> causes;
  if (!items.crossing.empty()) causes.push_back("the base crosses itself in " + named(items.crossing));
  if (!items.unextrudable.empty()) causes.push_back("base vertices cannot be extruded in " + named(items.unextrudable));
  if (!items.rest_faults.empty()) {
    const char* verb = items.rest_faults.size() == 1 ? " keeps" : " keep";
    causes.push_back(named(items.rest_faults) + verb + " the rest shell's own faults");
  }
  if (!items.touching.empty())
    causes.push_back("parts of the base touch or nearly touch in " + named(items.touching) +
                     " (closer than the layer can thin between them)");
  if (!items.unexplained.empty())
    causes.push_back(unguarded ? named(items.unexplained) + " unguarded (allow_invalid)"
                               : "the guard could not make " + named(items.unexplained) + " valid");
  std::string text = std::to_string(items.all.size()) + " of " + std::to_string(total) + " " + noun + "s " +
                     (items.all.size() == 1 ? "is" : "are") + " not valid: ";
  for (std::size_t i = 0; i < causes.size(); ++i) text += (i ? "; " : "") + causes[i];
  return text + " (report.json has each " + noun + "'s certificate)";
}

} // namespace gshell::detail
