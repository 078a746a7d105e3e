"""Finding the compiled `gshell` module.

Looked for, in this order:
  1. the folder set in the add-on's preferences (e.g. a build tree's build/python),
  2. the copy carried in this package's lib/ folder (what scripts/build zips),
  3. an installed one on Blender's sys.path (`cmake --install` puts it in Python's site folder).
The first that imports wins. The module is an extension built for one Python version and ABI
(Debian's Blender runs the system Python it was built for); when none imports, every attempt's
reason is kept for the error message.
"""
import glob
import importlib
import importlib.util
import os
import sys

import bpy

_ADDON = __package__
_cached = None
_failure = None


class ModuleUnavailable(RuntimeError):
    pass


class GShellPreferences(bpy.types.AddonPreferences):
    bl_idname = _ADDON

    module_dir: bpy.props.StringProperty(
        name="gshell module folder",
        description="Folder holding a gshell Python module (gshell*.so) to use instead of the one carried by "
                    "the add-on, e.g. a build tree's build/python. Takes effect after restarting Blender",
        subtype="DIR_PATH",
        default="",
        update=lambda self, context: _forget_failure(),
    )

    def draw(self, context):
        self.layout.prop(self, "module_dir")
        try:
            module = get()
            self.layout.label(text=f"Using {module.__file__}")
        except ModuleUnavailable as e:
            self.layout.label(text=str(e), icon="ERROR")


def _forget_failure():
    """A new folder may hold a module that loads (one already loaded stays until Blender restarts)."""
    global _failure
    _failure = None


def _load_file(path):
    spec = importlib.util.spec_from_file_location("gshell", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    sys.modules["gshell"] = module
    return module


def _module_files(folder):
    return sorted(glob.glob(os.path.join(folder, "gshell.*.so")) + glob.glob(os.path.join(folder, "gshell.*.pyd")))


def _preferences_dir():
    addon = bpy.context.preferences.addons.get(_ADDON)
    if addon is None or not addon.preferences.module_dir:
        return None
    return bpy.path.abspath(addon.preferences.module_dir)


def _load():
    if "gshell" in sys.modules:  # someone (a script, another add-on) imported it already
        return sys.modules["gshell"]
    failures = []
    folders = [d for d in (_preferences_dir(), os.path.join(os.path.dirname(__file__), "lib")) if d]
    for folder in folders:
        files = _module_files(folder)
        if not files and folder != folders[-1]:
            failures.append(f"{folder}: no gshell module there")
        for path in files:
            try:
                return _load_file(path)
            except ImportError as e:
                failures.append(f"{path}: {e}")
    try:
        return importlib.import_module("gshell")
    except ImportError as e:
        failures.append(f"installed module: {e}")
    py = sys.version_info
    raise ModuleUnavailable(f"the gshell Python module could not be loaded into Blender's Python "
                            f"{py.major}.{py.minor} ({'; '.join(failures)})")


def get():
    """The gshell module; raises ModuleUnavailable (with every reason) when it cannot be loaded."""
    global _cached, _failure
    if _cached is None and _failure is None:
        try:
            _cached = _load()
        except ModuleUnavailable as e:
            _failure = e
    if _failure is not None:
        raise _failure
    return _cached


def supports(function, keyword):
    """Whether a pybind11 function of the module takes `keyword` (its signature heads the docstring)."""
    doc = (getattr(function, "__doc__", None) or "").split("\n", 1)[0]
    return f"{keyword}:" in doc or f"{keyword}=" in doc
