"""For scripts that blender/headless/run runs (tests, examples, benchmarks): their arguments, and the
add-on installed from its zip and enabled the way a user does it (Preferences > Add-ons > Install...)."""
import math
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


def select(objects, active):
    """Exactly `objects` selected, `active` the active object (what operators act on)."""
    bpy.ops.object.select_all(action="DESELECT")
    for obj in objects:
        obj.select_set(True)
    bpy.context.view_layer.objects.active = active


def object_from_bmesh(bm, name):
    """A new object `name` with bm's geometry, linked to the active collection; frees bm."""
    mesh = bpy.data.meshes.new(name)
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.collection.objects.link(obj)
    return obj


def animate_bend(obj, degrees, first_frame, last_frame):
    """A Simple Deform modifier bending obj about its x axis, 0 degrees at first_frame to `degrees`
    at last_frame."""
    bend = obj.modifiers.new("Bend", "SIMPLE_DEFORM")
    bend.deform_method = "BEND"
    bend.deform_axis = "X"
    bend.angle = 0.0
    bend.keyframe_insert("angle", frame=first_frame)
    bend.angle = math.radians(degrees)
    bend.keyframe_insert("angle", frame=last_frame)
    return bend
