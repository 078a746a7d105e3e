"""For scripts that blender/headless/run runs (tests, examples, benchmarks): their arguments, and the
add-on installed from its zip and enabled the way a user does it (Preferences > Add-ons > Install...)."""
import os
import sys

import bpy


def script_args():
    """The arguments after Blender's `--`."""
    return sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []


def install_addon(zip_path):
    """Installs and enables gshell_blender from zip_path; returns the gshell module it loads."""
    bpy.ops.preferences.addon_install(filepath=os.path.abspath(zip_path))
    bpy.ops.preferences.addon_enable(module="gshell_blender")
    import gshell_blender
    return gshell_blender.gshell_module.get()
