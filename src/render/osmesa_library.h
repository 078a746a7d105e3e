#pragma once
// OSMesa (Mesa's off-screen software OpenGL) and the OpenGL 1.x calls the renderer makes, loaded
// with dlopen when something is first rendered. Linked instead, libOSMesa brings Mesa's LLVM into
// every process that links gshell: 0.4 M relocations and about 70 ms at every start of the CLI
// (measured against an empty program), for the few commands that render.
#ifdef GSHELL_HAVE_OSMESA
#include <GL/gl.h>
#include <GL/osmesa.h>

#include <string>

namespace gshell::detail {

/// Entry points of the loaded library, named as in OpenGL without the "gl" prefix (`Enable` is
/// glEnable); the types come from the headers the build found.
struct OSMesaLibrary {
  decltype(&::OSMesaCreateContextAttribs) OSMesaCreateContextAttribs;
  decltype(&::OSMesaMakeCurrent) OSMesaMakeCurrent;
  decltype(&::OSMesaPixelStore) OSMesaPixelStore;
  decltype(&::OSMesaDestroyContext) OSMesaDestroyContext;
  decltype(&::glBlendFunc) BlendFunc;
  decltype(&::glClear) Clear;
  decltype(&::glClearColor) ClearColor;
  decltype(&::glClipPlane) ClipPlane;
  decltype(&::glColorMaterial) ColorMaterial;
  decltype(&::glColorPointer) ColorPointer;
  decltype(&::glCullFace) CullFace;
  decltype(&::glDepthFunc) DepthFunc;
  decltype(&::glDepthMask) DepthMask;
  decltype(&::glDisable) Disable;
  decltype(&::glDrawArrays) DrawArrays;
  decltype(&::glEnable) Enable;
  decltype(&::glEnableClientState) EnableClientState;
  decltype(&::glFinish) Finish;
  decltype(&::glGetError) GetError;
  decltype(&::glLightModelfv) LightModelfv;
  decltype(&::glLightModeli) LightModeli;
  decltype(&::glLightfv) Lightfv;
  decltype(&::glLoadIdentity) LoadIdentity;
  decltype(&::glLoadMatrixd) LoadMatrixd;
  decltype(&::glMaterialfv) Materialfv;
  decltype(&::glMatrixMode) MatrixMode;
  decltype(&::glNormalPointer) NormalPointer;
  decltype(&::glShadeModel) ShadeModel;
  decltype(&::glVertexPointer) VertexPointer;
  decltype(&::glViewport) Viewport;
};

/// The library, loaded on the first call (thread-safe; it stays loaded), or nullptr when it cannot
/// be loaded or lacks an entry point; `why` (if given) then says which and what to install.
const OSMesaLibrary* osmesa_library(std::string* why = nullptr);

} // namespace gshell::detail
#endif
