"""gshell for Blender: shells over a mesh, detail bound inside them, and baked deformation.

Operators (Object menu search, and the "gshell" tab of the 3D view's sidebar):
  object.gshell_generate  shell of the active mesh -> new object "<name>.top"
  object.gshell_bind      bind the selected objects to the active object's shell
  object.gshell_unbind    release the selected detail objects
  object.gshell_bake      carry the shell and the bound detail through the base's animation,
                          written as point caches (PC2) played by Mesh Cache modifiers

The compiled `gshell` module travels inside this package (lib/); see gshell_module.py for where
else it is looked for.
"""

bl_info = {
    "name": "gshell",
    "author": "gshell authors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > gshell",
    "description": "Shells (offset layers cut into tets) over meshes, detail bound in them, baked deformation",
    "category": "Object",
}

if "bpy" in locals():
    # Reload scripts (F3 > Reload Scripts): pick up edited submodules too.
    import importlib

    for _name in ("gshell_module", "mesh_arrays", "shell_store", "point_cache", "op_generate", "op_bind",
                  "op_bake", "panel"):
        if _name in locals():
            importlib.reload(locals()[_name])

import bpy

from . import gshell_module, mesh_arrays, shell_store, point_cache, op_generate, op_bind, op_bake, panel

_classes = (
    gshell_module.GShellPreferences,
    shell_store.GShellObjectSettings,
    panel.GShellSceneSettings,
    op_generate.OBJECT_OT_gshell_generate,
    op_bind.OBJECT_OT_gshell_bind,
    op_bind.OBJECT_OT_gshell_unbind,
    op_bake.OBJECT_OT_gshell_bake,
    panel.VIEW3D_PT_gshell,
)


def _menu(self, context):
    self.layout.separator()
    self.layout.operator(op_generate.OBJECT_OT_gshell_generate.bl_idname, text="gshell: Generate Shell")
    self.layout.operator(op_bind.OBJECT_OT_gshell_bind.bl_idname, text="gshell: Bind to Shell")
    self.layout.operator(op_bind.OBJECT_OT_gshell_unbind.bl_idname, text="gshell: Unbind from Shell")
    self.layout.operator(op_bake.OBJECT_OT_gshell_bake.bl_idname, text="gshell: Bake Shell")


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)
    bpy.types.Object.gshell = bpy.props.PointerProperty(type=shell_store.GShellObjectSettings,
                                                        override=shell_store.OVERRIDABLE)
    bpy.types.Scene.gshell = bpy.props.PointerProperty(type=panel.GShellSceneSettings)
    bpy.types.VIEW3D_MT_object.append(_menu)


def unregister():
    bpy.types.VIEW3D_MT_object.remove(_menu)
    del bpy.types.Scene.gshell
    del bpy.types.Object.gshell
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
