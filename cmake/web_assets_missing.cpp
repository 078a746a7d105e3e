// Built instead of the embedded page when web/node_modules/three was missing at configure time
// (scripts/setup installs it with npm): `gshell view` then explains what to do.
#include "view/web_assets.h"

namespace gshell {

const std::vector<WebAsset>& web_assets() {
  static const std::vector<WebAsset> none;
  return none;
}

const char* three_version() { return ""; }

} // namespace gshell
