#pragma once
// The warning lines of a run whose frames or pose steps are not all valid, or not all converged
// (DeformRun::warnings, PoseResult::warnings): printed even with progress off, since report.json
// is otherwise the only place that says so.
#include <string>
#include <vector>

namespace gshell::detail {

/// Ids of the invalid items of one run (frames or steps, 1-based), sorted by what explains them;
/// an item may be in both `crossing` and `unextrudable`.
struct InvalidItems {
  std::vector<int> all;          ///< every invalid item
  std::vector<int> crossing;     ///< the base crosses itself there
  std::vector<int> unextrudable; ///< base vertices that cannot be extruded there
  std::vector<int> rest_faults;  ///< invalid only where the rest shell is not valid itself
  std::vector<int> touching;     ///< parts of the base nearly touch (closer than the layer can thin)
  std::vector<int> unexplained;  ///< none of these: left invalid by the guard (or unguarded)
  /// Files an invalid item under its causes.
  void add(int id, bool base_crosses, bool has_unextrudable, bool only_rest_faults, bool base_touches = false) {
    all.push_back(id);
    if (base_crosses) crossing.push_back(id);
    if (has_unextrudable) unextrudable.push_back(id);
    if (only_rest_faults) rest_faults.push_back(id);
    // Touching explains a frame only where nothing above does (a base crossing itself touches too).
    if (base_touches && !base_crosses && !has_unextrudable && !only_rest_faults) touching.push_back(id);
    else if (!base_crosses && !has_unextrudable && !only_rest_faults) unexplained.push_back(id);
  }
};

/// "frame 3", "frames 1, 2" (first_ids: up to ten, then "..."); `noun`: "frame" or "pose step".
std::string named_items(const std::string& noun, const std::vector<int>& ids);

/// "frames 1, 2 ran out of iterations before converging (--iterations N): CONSEQUENCE", or empty
/// when `ids` is empty or `max_iterations` is 0 (no iterations asked for, none ran out).
std::string unconverged_items_warning(const std::string& noun, const std::vector<int>& ids, int max_iterations,
                                      const std::string& consequence);

/// E.g. "2 of 4 frames are not valid: the base crosses itself in frames 3, 4; the guard could not
/// make frame 2 valid (report.json has each frame's certificate)"; items with only the rest
/// shell's own faults: "pose steps 1, 2 keep the rest shell's own faults". `noun`: "frame" or "pose step";
/// `unguarded`: the run asked for no guard (allow_invalid). Empty when nothing is invalid.
std::string invalid_items_warning(const InvalidItems& items, int total, const std::string& noun, bool unguarded);

} // namespace gshell::detail
