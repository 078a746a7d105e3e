"""object.gshell_bind: the selected objects become detail carried by the active object's shell."""
import bpy

from . import gshell_module, point_cache, shell_store


class OBJECT_OT_gshell_bind(bpy.types.Operator):
    """Bind the selected mesh objects to the active object's shell: baking the shell carries them along"""
    bl_idname = "object.gshell_bind"
    bl_label = "Bind to Shell"
    bl_options = {"REGISTER", "UNDO"}

    parent: bpy.props.BoolProperty(
        name="Parent to base", default=True,
        description="Parent the detail to the base (keeping where it is), so that moving the base as an object "
                    "moves the detail too; the bake carries the deformation")

    @classmethod
    def poll(cls, context):
        return shell_store.base_of(context.active_object) is not None

    def execute(self, context):
        base = shell_store.base_of(context.active_object)
        shell_store.flush_edits(context)
        try:
            gshell = gshell_module.get()
            shell = shell_store.rest_shell(gshell, base)
            to_base = shell_store.inverted(base, base.matrix_world)
        except (gshell_module.ModuleUnavailable, shell_store.ShellError) as e:
            self.report({"ERROR"}, f"gshell: {e}")
            return {"CANCELLED"}
        top = base.gshell.top
        details = [o for o in context.selected_objects if o not in (base, top, context.active_object)]
        if not details:
            self.report({"ERROR"}, f"gshell: select the detail objects, then the shell of '{base.name}' last (active)")
            return {"CANCELLED"}
        # Every detail is checked (embedded) before any is changed: one bound half way would make
        # every later bake of the base fail on it.
        problems, bindings = [], []
        for o in details:
            if o.type != "MESH":
                problems.append(f"'{o.name}' is not a mesh")
            elif o.gshell.role in ("BASE", "TOP"):
                problems.append(f"'{o.name}' is part of a shell ({o.gshell.role.lower()})")
            elif self.parent and _ancestor(o, base):  # Blender would refuse the loop without a word
                problems.append(f"'{o.name}' is a parent of '{base.name}' and cannot also be its child (untick "
                                f"Parent, or clear the parenting first)")
            else:
                matrix = to_base @ o.matrix_world
                try:
                    bindings.append((o, matrix, shell_store.embed_detail(gshell, shell, o, matrix)[0]))
                except shell_store.ShellError as e:
                    problems.append(str(e))
        if problems:
            self.report({"ERROR"}, "gshell: cannot bind: " + "; ".join(problems))
            return {"CANCELLED"}

        points = outside = 0
        farthest = 0.0
        for detail, matrix, embedding in bindings:
            detail.gshell.role = "DETAIL"
            detail.gshell.base = base
            detail.gshell.bind_matrix = matrix
            detail[shell_store.OUTSIDE_KEY] = len(embedding.outside)  # a bake warns if more are later
            points += len(embedding)
            outside += len(embedding.outside)
            farthest = max(farthest, embedding.max_outside_distance)
            if self.parent and detail.parent != base:
                world = detail.matrix_world.copy()
                detail.parent = base
                detail.matrix_parent_inverse = to_base
                detail.matrix_world = world
        message = f"gshell: bound {len(details)} object(s), {points} vertices, to the shell of '{base.name}'"
        if outside:
            message += (f"; {outside} vertices lie outside the shell (up to {farthest:.3g} away, local units) "
                        f"and follow the nearest tet")
        self.report({"WARNING"} if outside else {"INFO"}, message)
        return {"FINISHED"}


def _ancestor(obj, of):
    """Whether obj is a parent of `of`, directly or through others."""
    p = of.parent
    while p is not None:
        if p == obj:
            return True
        p = p.parent
    return False


class OBJECT_OT_gshell_unbind(bpy.types.Operator):
    """Release the selected detail objects from their shells (their baked motion is removed too)"""
    bl_idname = "object.gshell_unbind"
    bl_label = "Unbind from Shell"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return any(o.gshell.role == "DETAIL" for o in context.selected_objects)

    def execute(self, context):
        details = [o for o in context.selected_objects if o.gshell.role == "DETAIL"]
        for detail in details:
            detail.gshell.role = "NONE"
            detail.gshell.base = None
            point_cache.detach(detail)
        self.report({"INFO"}, f"gshell: unbound {len(details)} object(s)")
        return {"FINISHED"}
