"""Where a shell lives in a .blend file, and how to get it back as a gshell.Shell.

A shell joins three kinds of objects, marked by `Object.gshell.role`:
  BASE    the artist's mesh; `gshell.top` points to its top object. Its mesh data (without
          modifiers) is the rest base.
  TOP     "<base>.top", made by Generate: same vertices in the same order as the base, parented to
          the base with an identity transform (it always has the base's transform). Its mesh data
          is the rest top; it keeps the shell's triangles (ID property "gshell_faces", int32 3m: the
          base's polygons as cut by Generate), the thickness, the generate report ("gshell_report",
          JSON text) and a digest of the base's positions then ("gshell_rest_base"): a base edited
          since, or with a transform applied, no longer fits its top and must be generated again.
  DETAIL  an object bound with Bind: `gshell.base` points to the base; `gshell.bind_matrix` maps its
          local coordinates into the base's local space as they were at binding time.
A baked object also keeps `gshell.cache_name`, the name of its cache file (a base: of its cache
folder), so that it keeps the file while other objects come and go (see op_bake.cache_names).
Everything the shell solver sees is in the base's local space (object transforms are not part of
the shell), so a moved, rotated or scaled base carries its shell along.
"""
import hashlib

import numpy as np

import bpy

from . import mesh_arrays

FACES_KEY = "gshell_faces"
REPORT_KEY = "gshell_report"
REST_BASE_KEY = "gshell_rest_base"  # rest_fingerprint of the base's positions at Generate
OUTSIDE_KEY = "gshell_outside"  # on a detail: how many of its vertices lay outside the shell at Bind
BAKE_REPORT_KEY = "gshell_bake"


class ShellError(Exception):
    """A problem the user can fix (reported as a Blender error, nothing is changed)."""


# A base that is a library override (a linked character made editable) keeps its settings in the
# file only where they are overridable: linked data itself is never saved.
OVERRIDABLE = {"LIBRARY_OVERRIDABLE"}


class GShellObjectSettings(bpy.types.PropertyGroup):
    role: bpy.props.EnumProperty(
        name="gshell role", override=OVERRIDABLE,
        items=[("NONE", "None", "Not part of a shell"),
               ("BASE", "Base", "The surface a shell was generated on"),
               ("TOP", "Top", "The top surface of a shell"),
               ("DETAIL", "Detail", "Geometry bound inside a shell, carried when the shell is baked")],
        default="NONE")
    top: bpy.props.PointerProperty(type=bpy.types.Object, name="Top", override=OVERRIDABLE,
                                   description="The top object of this base's shell")
    base: bpy.props.PointerProperty(type=bpy.types.Object, name="Base", override=OVERRIDABLE,
                                    description="The base object of the shell this top or detail belongs to")
    thickness: bpy.props.FloatProperty(name="Thickness", min=0.0, override=OVERRIDABLE,
                                       description="The shell's thickness eta, in the base's local units")
    bind_matrix: bpy.props.FloatVectorProperty(
        name="Bind matrix", size=(4, 4), subtype="MATRIX", override=OVERRIDABLE,
        description="Detail local space to base local space at binding time")
    cache_name: bpy.props.StringProperty(
        name="Cache name", override=OVERRIDABLE,
        description="File name of this object's baked cache (a base: of its cache folder), given by its last "
                    "completed bake and kept so that no other object's cache takes it")


def flush_edits(context):
    """Writes what Edit Mode holds into the meshes, staying in Edit Mode: a mesh's data lags its edits
    until then, so a base edited and not yet left read as unchanged (its rest check passed) while
    its animated frames carried the edit."""
    for obj in context.objects_in_mode or ():
        if obj.type == "MESH" and obj.mode == "EDIT":
            obj.update_from_editmode()


def base_of(obj):
    """The base of the shell `obj` belongs to (obj itself for a base), or None."""
    if obj is None:
        return None
    role = obj.gshell.role
    if role == "BASE":
        return obj
    if role in ("TOP", "DETAIL"):
        return obj.gshell.base
    return None


def top_of(base):
    top = base.gshell.top
    if base.gshell.role != "BASE" or top is None or top.gshell.base != base or FACES_KEY not in top:
        raise ShellError(f"'{base.name}' has no shell: run Generate Shell on it first")
    if not top.users_collection:  # deleted from the scene; base.gshell.top keeps it in the file
        raise ShellError(f"the top of '{base.name}' was deleted: run Generate Shell on it again")
    return top


def shell_faces(top):
    return np.asarray(top[FACES_KEY], dtype=np.int64).reshape(-1, 3)


def rest_fingerprint(V):
    """A digest of rest base positions (n, 3) as Blender stores them (float32)."""
    return hashlib.sha256(np.ascontiguousarray(V, dtype="<f4").tobytes()).hexdigest()


def _identity(matrix):
    return all(abs(matrix[i][j] - (i == j)) <= 1e-6 for i in range(4) for j in range(4))


def rest_shell(gshell, base):
    """gshell.Shell of `base` at rest (base and top mesh data, stored faces and thickness)."""
    top = top_of(base)
    V = mesh_arrays.vertex_positions(base.data)
    T = mesh_arrays.vertex_positions(top.data)
    F = shell_faces(top)
    if len(V) != len(T) or (len(F) and F.max() >= len(V)):
        raise ShellError(f"'{base.name}' has {len(V)} vertices but its shell '{top.name}' {len(T)}: the meshes were "
                         f"edited since the shell was made; run Generate Shell again")
    stored = top.get(REST_BASE_KEY)  # files from before the digest have none: taken as they are
    if stored is not None and stored != rest_fingerprint(V):
        raise ShellError(f"'{base.name}' was changed since its shell was made (its mesh edited, or a transform "
                         f"applied to it): its top no longer fits; run Generate Shell again")
    if top.parent != base or not _identity(top.matrix_parent_inverse) or not _identity(top.matrix_basis):
        raise ShellError(f"'{top.name}' no longer has the transform of '{base.name}' (it was moved, re-parented, or "
                         f"a transform was applied to '{base.name}'): run Generate Shell again")
    try:
        return gshell.Shell(V, F, T, top.gshell.thickness)
    except ValueError as e:
        raise ShellError(f"the shell of '{base.name}' cannot be used ({e}); run Generate Shell again") from e


def details_of(base, scene):
    return [o for o in scene.objects if o.gshell.role == "DETAIL" and o.gshell.base == base and o.type == "MESH"]


def transform(matrix, P):
    """Points (k, 3) mapped by a 4x4 affine matrix."""
    A = np.array(matrix, dtype=np.float64)
    return P @ A[:3, :3].T + A[:3, 3]


def inverted(obj, matrix):
    """matrix.inverted(), or a ShellError naming obj: a scale of 0 (its own or a parent's) flattens it
    for good, and a detail's carried points go back to it through the inverse of its bind matrix."""
    try:
        return matrix.inverted()
    except ValueError:
        raise ShellError(f"'{obj.name}': flattened by a scale of 0 (its own or a parent's), its transform has "
                         f"no inverse") from None


def embed_detail(gshell, shell, detail, bind_matrix):
    """(gshell.embed of the detail's vertices mapped by bind_matrix, the matrix back to its local space),
    or a ShellError naming the detail. Bind checks every detail with it before binding any, and the bake
    before writing anything, so neither fails half way."""
    back = inverted(detail, bind_matrix)
    try:
        return gshell.embed(shell, transform(bind_matrix, mesh_arrays.vertex_positions(detail.data))), back
    except ValueError as e:  # e.g. a non-finite vertex
        raise ShellError(f"'{detail.name}': gshell.embed refuses its vertices (points[i] is vertex i, in the "
                         f"base's local space): {e}") from e
