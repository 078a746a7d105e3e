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

/// The entry points the renderer calls, once each: X(member, symbol). OpenGL's are named without
/// the "gl" prefix (`Enable` is glEnable).
#define GSHELL_OSMESA_ENTRY_POINTS(X)                                                                \
  X(OSMesaCreateContextAttribs, OSMesaCreateContextAttribs)                                          \
  X(OSMesaMakeCurrent, OSMesaMakeCurrent) X(OSMesaPixelStore, OSMesaPixelStore)                      \
  X(OSMesaDestroyContext, OSMesaDestroyContext) X(BlendFunc, glBlendFunc) X(Clear, glClear)          \
  X(ClearColor, glClearColor) X(ClipPlane, glClipPlane) X(ColorMaterial, glColorMaterial)            \
  X(ColorPointer, glColorPointer) X(CullFace, glCullFace) X(DepthFunc, glDepthFunc)                  \
  X(DepthMask, glDepthMask) X(Disable, glDisable) X(DrawArrays, glDrawArrays) X(Enable, glEnable)    \
  X(EnableClientState, glEnableClientState) X(Finish, glFinish) X(GetError, glGetError)              \
  X(LightModelfv, glLightModelfv) X(LightModeli, glLightModeli) X(Lightfv, glLightfv)                \
  X(LoadIdentity, glLoadIdentity) X(LoadMatrixd, glLoadMatrixd) X(Materialfv, glMaterialfv)          \
  X(MatrixMode, glMatrixMode) X(NormalPointer, glNormalPointer) X(ShadeModel, glShadeModel)          \
  X(VertexPointer, glVertexPointer) X(Viewport, glViewport)

/// Entry points of the loaded library; the types come from the headers the build found.
struct OSMesaLibrary {
#define GSHELL_OSMESA_MEMBER(member, symbol) decltype(&::symbol) member;
  GSHELL_OSMESA_ENTRY_POINTS(GSHELL_OSMESA_MEMBER)
#undef GSHELL_OSMESA_MEMBER
};

/// The library, loaded on the first call (thread-safe; it stays loaded), or nullptr when it cannot
/// be loaded or lacks an entry point; `why` (if given) then says which and what to install.
const OSMesaLibrary* osmesa_library(std::string* why = nullptr);

} // namespace gshell::detail
#endif
