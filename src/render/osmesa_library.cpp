#include "render/osmesa_library.h"

#ifdef GSHELL_HAVE_OSMESA
#include <dlfcn.h>

#include <optional>
#include <string>

namespace gshell::detail {

namespace {

struct Loaded {
  std::optional<OSMesaLibrary> library;
  std::string why; // when not loaded
};

template <class Function> bool bind(void* handle, const char* name, Function& f, std::string& why) {
  f = reinterpret_cast<Function>(dlsym(handle, name));
  if (!f) why = std::string("libOSMesa has no ") + name;
  return f != nullptr;
}

Loaded load() {
  Loaded loaded;
  // The runtime library's name (Debian's libosmesa6), then the development symlink.
  void* handle = dlopen("libOSMesa.so.8", RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* error = dlerror(); // about the name users should install, not the fallback
    loaded.why = std::string("cannot load libOSMesa.so.8 (install libosmesa6)") + (error ? ": " + std::string(error) : "");
    if (!(handle = dlopen("libOSMesa.so", RTLD_NOW | RTLD_LOCAL))) return loaded;
    loaded.why.clear();
  }
  OSMesaLibrary l{};
  bool all = true;
#define GSHELL_OSMESA_BIND(member, symbol) all = all && bind(handle, #symbol, l.member, loaded.why);
  GSHELL_OSMESA_ENTRY_POINTS(GSHELL_OSMESA_BIND)
#undef GSHELL_OSMESA_BIND
  if (all) loaded.library = l;
  return loaded; // the handle stays open: the process may render again
}

} // namespace

const OSMesaLibrary* osmesa_library(std::string* why) {
  static const Loaded loaded = load();
  if (!loaded.library && why) *why = loaded.why;
  return loaded.library ? &*loaded.library : nullptr;
}

} // namespace gshell::detail
#endif
