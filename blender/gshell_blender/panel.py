"""The "gshell" tab of the 3D view's sidebar."""
import json

import bpy

from . import gshell_module, op_generate, point_cache, shell_store


@op_generate.generate_properties
class GShellSceneSettings(bpy.types.PropertyGroup):
    """The sidebar's generate options (handed to object.gshell_generate)."""


class VIEW3D_PT_gshell(bpy.types.Panel):
    bl_label = "gshell"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "gshell"

    def draw(self, context):
        layout = self.layout
        try:
            module = gshell_module.get()
        except gshell_module.ModuleUnavailable as e:
            layout.label(text="gshell module not loaded", icon="ERROR")
            layout.label(text=str(e)[:200])
            return
        obj = context.active_object
        settings = context.scene.gshell

        box = layout.box()
        box.label(text="Shell", icon="MOD_SOLIDIFY")
        box.prop(settings, "thickness_mode", expand=True)
        box.prop(settings, "thickness_ratio" if settings.thickness_mode == "RATIO" else "thickness")
        box.prop(settings, "method")
        box.prop(settings, "iterations")
        if gshell_module.supports(module.generate, "allow_invalid"):
            box.prop(settings, "allow_invalid")
        op = box.operator(op_generate.OBJECT_OT_gshell_generate.bl_idname)
        for name in ("thickness_mode", "thickness_ratio", "thickness", "method", "iterations", "allow_invalid"):
            setattr(op, name, getattr(settings, name))

        base = shell_store.base_of(obj)
        if base is not None and base.gshell.role == "BASE" and base.gshell.top is not None:
            top = base.gshell.top
            report = json.loads(top.get(shell_store.REPORT_KEY, "{}") or "{}")
            if report:
                box.label(text=f"'{top.name}': {op_generate.validity(report)}")
                box.label(text=f"stretch max {report['stretch']['max']:.3g}, {op_generate.inverted_tets(report)} inverted")
            box = layout.box()
            box.label(text="Detail and bake", icon="RENDER_ANIMATION")
            row = box.row(align=True)
            row.operator("object.gshell_bind")
            row.operator("object.gshell_unbind")
            details = shell_store.details_of(base, context.scene)
            box.label(text=f"{len(details)} bound object(s)")
            row = box.row(align=True)
            row.prop(context.scene, "frame_start", text="Start")
            row.prop(context.scene, "frame_end", text="End")
            box.operator("object.gshell_bake")
            mod = top.modifiers.get(point_cache.MODIFIER_NAME)
            if mod is not None:
                box.label(text=f"cache: {mod.filepath}")
        elif obj is not None and obj.gshell.role == "DETAIL":
            layout.operator("object.gshell_unbind")
        elif obj is not None and obj.type == "MESH":
            layout.label(text=f"'{obj.name}' has no shell yet")
