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
  std::string& why = loaded.why;
  const bool all = bind(handle, "OSMesaCreateContextAttribs", l.OSMesaCreateContextAttribs, why) &&
                   bind(handle, "OSMesaMakeCurrent", l.OSMesaMakeCurrent, why) &&
                   bind(handle, "OSMesaPixelStore", l.OSMesaPixelStore, why) &&
                   bind(handle, "OSMesaDestroyContext", l.OSMesaDestroyContext, why) &&
                   bind(handle, "glBlendFunc", l.BlendFunc, why) && bind(handle, "glClear", l.Clear, why) &&
                   bind(handle, "glClearColor", l.ClearColor, why) && bind(handle, "glClipPlane", l.ClipPlane, why) &&
                   bind(handle, "glColorMaterial", l.ColorMaterial, why) &&
                   bind(handle, "glColorPointer", l.ColorPointer, why) && bind(handle, "glCullFace", l.CullFace, why) &&
                   bind(handle, "glDepthFunc", l.DepthFunc, why) && bind(handle, "glDepthMask", l.DepthMask, why) &&
                   bind(handle, "glDisable", l.Disable, why) && bind(handle, "glDrawArrays", l.DrawArrays, why) &&
                   bind(handle, "glEnable", l.Enable, why) &&
                   bind(handle, "glEnableClientState", l.EnableClientState, why) &&
                   bind(handle, "glFinish", l.Finish, why) && bind(handle, "glGetError", l.GetError, why) &&
                   bind(handle, "glLightModelfv", l.LightModelfv, why) &&
                   bind(handle, "glLightModeli", l.LightModeli, why) && bind(handle, "glLightfv", l.Lightfv, why) &&
                   bind(handle, "glLoadIdentity", l.LoadIdentity, why) &&
                   bind(handle, "glLoadMatrixd", l.LoadMatrixd, why) && bind(handle, "glMaterialfv", l.Materialfv, why) &&
                   bind(handle, "glMatrixMode", l.MatrixMode, why) &&
                   bind(handle, "glNormalPointer", l.NormalPointer, why) &&
                   bind(handle, "glShadeModel", l.ShadeModel, why) &&
                   bind(handle, "glVertexPointer", l.VertexPointer, why) && bind(handle, "glViewport", l.Viewport, why);
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
