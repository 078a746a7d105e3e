#pragma once
// The files the viewer serves: its page (web/page/) and three.js (npm package `three`), embedded
// into the library at build time (cmake/embed_web_assets.cmake), so `gshell view` works offline
// and from any folder.
#include <cstddef>
#include <string_view>
#include <vector>

namespace gshell {

struct WebAsset {
  std::string_view path;         ///< URL path, e.g. "/index.html", "/three/three.module.js"
  std::string_view content_type; ///< e.g. "text/javascript; charset=utf-8"
  std::string_view bytes;
};

/// Every embedded file; empty when the library was built without three.js (scripts/setup installs it).
const std::vector<WebAsset>& web_assets();

/// The embedded three.js version ("" when there is none).
const char* three_version();

} // namespace gshell
