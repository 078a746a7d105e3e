"""object.gshell_generate: the shell of the active mesh object, as a new object "<name>.top"."""
import json
import re
import struct

import bpy
from mathutils import Matrix

from . import gshell_module, mesh_arrays, point_cache, shell_store

METHODS = [
    ("rigid", "Rigid", "Optimised towards the normal prisms (the paper's method)"),
    ("curvature", "Curvature", "As rigid, with the ideal prisms scaled by the surface's curvature "
                               "(no groove along sharp ridges)"),
    ("offset", "Offset", "Vertex-normal offset, no optimisation (the baseline)"),
]
THICKNESS_MODES = [
    ("RATIO", "Ratio", "Thickness relative to the radius of the mesh's bounding sphere"),
    ("ABSOLUTE", "Absolute", "Thickness in the object's local units"),
]


def as_typed(value):
    """The shortest decimal that rounds to the same single-precision float as `value` (a float
    property's value): 0.03 for the 0.029999999329447746 that Blender holds of a typed 0.03."""
    single = struct.unpack("f", struct.pack("f", value))[0]
    for digits in range(1, 10):
        shortest = float(f"{single:.{digits}g}")
        if struct.unpack("f", struct.pack("f", shortest))[0] == single:
            return shortest
    return single


def axis_scales(matrix):
    """The scale of each local axis in the world: the lengths of the matrix's axes. (to_scale() gives a
    mirror's sign to every axis, so a mirrored object, scale (-1, 1, 1), read as (-1, -1, -1).)"""
    return [matrix.col[axis].xyz.length for axis in range(3)]


def generate_properties(cls):
    """The generate options, shared by the operator and the sidebar's scene settings."""
    if "__annotations__" not in cls.__dict__:
        cls.__annotations__ = {}
    cls.__annotations__.update({
        "thickness_mode": bpy.props.EnumProperty(name="Thickness", items=THICKNESS_MODES, default="RATIO"),
        "thickness_ratio": bpy.props.FloatProperty(
            name="Thickness ratio", default=0.03, min=1e-6, soft_max=0.5, precision=4, step=0.1,
            description="Shell thickness as a ratio of the bounding sphere's radius (centre = bounding-box "
                        "centre, radius = farthest vertex)"),
        "thickness": bpy.props.FloatProperty(
            name="Thickness", default=0.05, min=1e-9, soft_max=10.0, precision=4, unit="LENGTH",
            description="Shell thickness in the object's local units"),
        "method": bpy.props.EnumProperty(name="Method", items=METHODS, default="rigid"),
        "iterations": bpy.props.IntProperty(name="Iterations", default=50, min=0, soft_max=500,
                                            description="Maximum local/global iterations of the optimising methods"),
        "allow_invalid": bpy.props.BoolProperty(
            name="Allow invalid", default=False,
            description="Rigid and curvature: skip the validity guard and keep the paper's unguarded shell, "
                        "which may have inverted tets or intersections (the status bar says whether it is valid)"),
    })
    return cls


def in_polygons(message, polygon):
    """The module numbers the triangles it was given; name the Blender polygons they came from."""
    def known(ts):
        return all(0 <= t < len(polygon) for t in ts)

    def polygons(ts, joiner):
        ps = [str(polygon[t]) for t in ts]
        return f"polygon {ps[0]}" if len(set(ps)) == 1 else f"polygons {joiner.join(ps)}"

    def triangle(match):
        t = int(match.group(1))
        if not known([t]):
            return match.group(0)
        return f"triangle {t}{match.group(2) or ''} of polygon {polygon[t]}"

    def pair(match):  # orientation clashes and duplicated faces
        ts = [int(match.group(1)), int(match.group(2))]
        if not known(ts):
            return match.group(0)
        return f"triangles {ts[0]} and {ts[1]} of {polygons(ts, ' and ')}"

    def triangles(match):  # non-manifold edges: "faces (a, b, c)", or "(a, ..., f, ...)" past six
        listed = match.group(1)
        ts = [int(t) for t in re.findall(r"\d+", listed)]
        if not known(ts):
            return match.group(0)
        more = ", ..." if listed.endswith("...") else ""
        return f"triangles ({listed}) of polygons ({', '.join(str(polygon[t]) for t in ts)}{more})"

    message = re.sub(r"\bfaces (\d+) and (\d+)\b", pair, message)
    message = re.sub(r"\bface (\d+)( \([\d, ]+\))?", triangle, message)
    return re.sub(r"\bfaces \(([\d, ]+(?:, \.\.\.)?)\)", triangles, message)


def for_blender(message, polygon=None):
    """A module message in Blender's terms: without the module's name for its arguments, polygons
    for the triangles it numbers, and Blender's tool where the CLI's is advised."""
    message = message.removeprefix("mesh (V, F): ")
    message = message.replace("`gshell convert --weld` joins them", "Merge by Distance (Mesh > Clean Up) joins them")
    return in_polygons(message, polygon) if polygon is not None else message


def inverted_tets(report):
    """The shell's inverted tets: the exact certificate's count (older reports: the top-level key)."""
    return report.get("certificate", {}).get("inverted_tets", report.get("inverted_tets", 0))


def validity(report):
    """One phrase about the shell's validity from its report."""
    if isinstance(report.get("valid"), bool):
        return "valid" if report["valid"] else "NOT valid"
    inverted = inverted_tets(report)
    crossings = [report.get("certificate", report).get(k) for k in ("top_self_intersections", "top_base_intersections")]
    if inverted or any(crossings):
        return "NOT valid"
    if any(c is None for c in crossings):
        return "no inverted tets (intersections not counted)"
    return "valid (no inverted tets, no intersections)"


def summary(report):
    s = report["stretch"]
    return (f"stretch mean {s['mean']:.3g}, max {s['max']:.3g}; {inverted_tets(report)} inverted tets; "
            f"{validity(report)}")


def _top_object(base, name, mesh, context):
    """Reuses the base's top object when it has one (regenerate), else makes and links a new one."""
    top = base.gshell.top
    if base.gshell.role == "BASE" and top is not None and top.gshell.base == base and top.type == "MESH":
        old = top.data
        top.data = mesh
        if old.users == 0:
            bpy.data.meshes.remove(old)
        # The bakes of the previous shell, the top's and its details' (they play together or not at all).
        for obj in [top] + shell_store.details_of(base, context.scene):
            point_cache.detach(obj)
        if not top.users_collection:  # deleted from the scene (base.gshell.top kept it in the file)
            _link(top, base, context)
    else:
        top = bpy.data.objects.new(name, mesh)
        _link(top, base, context)
        top.display_type = "WIRE"  # the base and the detail inside stay visible
    top.parent = base  # the same transform as the base, always
    top.matrix_parent_inverse = Matrix.Identity(4)
    top.matrix_basis = Matrix.Identity(4)
    return top


def _link(top, base, context):
    for collection in base.users_collection or [context.collection]:
        collection.objects.link(top)


@generate_properties
class OBJECT_OT_gshell_generate(bpy.types.Operator):
    """Generate the shell of the active mesh object: a new object "<name>.top" over the same vertices"""
    bl_idname = "object.gshell_generate"
    bl_label = "Generate Shell"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return context.active_object is not None and context.active_object.type == "MESH"

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "thickness_mode", expand=True)
        layout.prop(self, "thickness_ratio" if self.thickness_mode == "RATIO" else "thickness")
        layout.prop(self, "method")
        optimised = layout.column()
        optimised.enabled = self.method != "offset"  # the offset is not optimised
        optimised.prop(self, "iterations")
        try:
            if gshell_module.supports(gshell_module.get().generate, "allow_invalid"):
                optimised.prop(self, "allow_invalid")
        except gshell_module.ModuleUnavailable:
            pass

    def execute(self, context):
        base = context.active_object
        # In Edit Mode a mesh's data lags the edits and its UV layers read as empty: generate in
        # Object Mode and go back.
        editing = base.mode == "EDIT"
        if editing:
            bpy.ops.object.mode_set(mode="OBJECT")
        try:
            return self._execute(context, base)
        finally:
            if editing:
                bpy.ops.object.mode_set(mode="EDIT")

    def _execute(self, context, base):
        try:
            gshell = gshell_module.get()
            shell, V, faces, polygon = self._generate(gshell, base)
        except (gshell_module.ModuleUnavailable, shell_store.ShellError) as e:
            self.report({"ERROR"}, f"gshell: {e}")
            return {"CANCELLED"}

        mesh = mesh_arrays.mesh_like(base.data, f"{base.name}.top", shell.top)
        top = _top_object(base, f"{base.name}.top", mesh, context)
        top[shell_store.FACES_KEY] = faces.ravel()
        top[shell_store.REPORT_KEY] = json.dumps(shell.report, indent=1)
        top[shell_store.REST_BASE_KEY] = shell_store.rest_fingerprint(V)
        top.gshell.role = "TOP"
        top.gshell.base = base
        top.gshell.thickness = shell.thickness
        base.gshell.role = "BASE"
        base.gshell.top = top

        self.report({"INFO"}, f"gshell: '{top.name}': {summary(shell.report)}")
        for warning in shell.report.get("warnings", []):  # base crossings, unextrudable vertices, not valid
            self.report({"WARNING"}, f"gshell: '{base.name}': {for_blender(warning, polygon)}")
        scale = axis_scales(base.matrix_world)
        if max(scale) > 1.0001 * min(scale):
            self.report({"WARNING"}, f"gshell: '{base.name}' is scaled unevenly {tuple(round(s, 3) for s in scale)}: "
                                     f"the shell is even in local units, not in the scene (apply the scale to "
                                     f"'{base.name}', then Generate Shell again)")
        return {"FINISHED"}

    def _generate(self, gshell, base):
        if base.gshell.role in ("TOP", "DETAIL") and base.gshell.base is not None:  # a base gone: a plain mesh
            owner = base.gshell.base.name
            kind = "the top of" if base.gshell.role == "TOP" else "bound as detail to"
            raise shell_store.ShellError(f"'{base.name}' is {kind} the shell of '{owner}'")
        if base.library is not None:  # linked: nothing set on it would be saved
            raise shell_store.ShellError(
                f"'{base.name}' is linked from {base.library.filepath} and cannot be changed here: make a library "
                f"override of it first (Object > Library Override > Make), then Generate Shell on that")
        V = mesh_arrays.vertex_positions(base.data)
        F, polygon = mesh_arrays.triangles(base.data)
        if len(F) == 0:
            raise shell_store.ShellError(f"'{base.name}' has no faces")
        # The offset is not optimised: the module refuses iteration options with it.
        optimised = self.method != "offset"
        kwargs = {"method": self.method}
        if optimised:
            kwargs["iterations"] = self.iterations
        # Blender keeps float properties in single precision: 0.03 is 0.029999999329447746. The
        # value typed is the one meant, so it goes on as the shortest decimal that float holds.
        if self.thickness_mode == "RATIO":
            kwargs["thickness_ratio"] = as_typed(self.thickness_ratio)
        else:
            kwargs["thickness"] = as_typed(self.thickness)
        if optimised and gshell_module.supports(gshell.generate, "allow_invalid"):
            kwargs["allow_invalid"] = self.allow_invalid
        wm = bpy.context.window_manager

        def show(update):  # the paper's iterations as the cursor's number while the UI waits
            if update.get("stage", "paper") == "paper":  # (older modules named no stage unguarded)
                wm.progress_update(update["iteration"])
        if gshell_module.supports(gshell.generate, "progress"):
            kwargs["progress"] = show
        wm.progress_begin(0, self.iterations)
        try:
            return gshell.generate(V, F, **kwargs), V, F, polygon
        except ValueError as e:
            raise shell_store.ShellError(f"'{base.name}': {for_blender(str(e), polygon)}") from e
        finally:
            wm.progress_end()
