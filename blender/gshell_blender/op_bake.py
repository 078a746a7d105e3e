"""object.gshell_bake: carry a shell and its bound detail through the base's animation.

For each frame the base is evaluated with its modifiers and animation (armature, shape keys,
simple deform, ...), the top follows through gshell.Deformer (factored once per bake, each frame
warm-started from the previous one, so frames are solved in order), and the detail through its
embedding in the shell. The results go to PC2 point caches played by Mesh Cache modifiers (see
point_cache.py, and README "Blender add-on" for why a cache rather than shape keys).
"""
import json
import os
import sys
import time

import bpy

from . import gshell_module, mesh_arrays, point_cache, shell_store

DEFAULT_DIRECTORY = "//gshell_cache/"

# Modifiers that only move vertices (keep their number and order).
_DEFORM_ONLY = {"ARMATURE", "CAST", "CURVE", "DISPLACE", "HOOK", "LAPLACIANDEFORM", "LATTICE", "MESH_DEFORM",
                "SHRINKWRAP", "SIMPLE_DEFORM", "SMOOTH", "CORRECTIVE_SMOOTH", "LAPLACIANSMOOTH", "SURFACE_DEFORM",
                "WARP", "WAVE", "MESH_CACHE", "MESH_SEQUENCE_CACHE", "CLOTH", "SOFT_BODY", "WEIGHTED_NORMAL",
                "NORMAL_EDIT", "UV_PROJECT", "UV_WARP", "VERTEX_WEIGHT_EDIT", "VERTEX_WEIGHT_MIX",
                "VERTEX_WEIGHT_PROXIMITY", "DATA_TRANSFER", "TRIANGULATE"}


def evaluated_base_positions(base, depsgraph, num_vertices):
    """The base's vertices at the current frame, after its modifiers, in its local space."""
    evaluated = base.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        if len(mesh.vertices) != num_vertices:
            changing = [m.name for m in base.modifiers if m.show_viewport and m.type not in _DEFORM_ONLY]
            raise shell_store.ShellError(
                f"'{base.name}' has {len(mesh.vertices)} vertices after its modifiers at frame "
                f"{depsgraph.scene.frame_current}, its shell {num_vertices}: the bake needs the same vertices in the "
                f"same order (hide the modifiers that change them in the viewport while baking: "
                f"{', '.join(changing) or 'none found'})")
        return mesh_arrays.vertex_positions(mesh)
    finally:
        evaluated.to_mesh_clear()


def cache_names(objects, reserved=()):
    """Names for the objects' cache files (or folders), distinct from each other's and from `reserved`,
    case aside (case-insensitive file systems). Blender's names are distinct but their clean names need
    not be ('ball 1' and 'ball_1' are both ball_1): a clash takes the first free .001, .002, ... as
    Blender numbers duplicates. The name an object's last bake gave it (gshell.cache_name) stays its own
    while it still fits the object's name and is free, and is served first, so objects coming and going
    never move another's cache; a duplicated object carries its original's and gets its own."""
    def fits(obj, name):
        stem = bpy.path.clean_name(obj.name)
        return name == stem or (name.startswith(stem + ".") and name[len(stem) + 1:].isdigit())

    taken = {name.casefold() for name in reserved}
    names = [None] * len(objects)
    for i, obj in enumerate(objects):
        name = obj.gshell.cache_name
        if fits(obj, name) and name.casefold() not in taken:
            names[i] = name
            taken.add(name.casefold())
    for i, obj in enumerate(objects):
        if names[i] is None:
            stem = name = bpy.path.clean_name(obj.name)
            number = 0
            while name.casefold() in taken:
                number += 1
                name = f"{stem}.{number:03d}"
            names[i] = name
            taken.add(name.casefold())
    return names


def cache_directory(base, directory):
    """(absolute folder for this base's caches, its name, warning or None)."""
    warning = None
    # Empty is the default folder, "~" the home folder, and other relative paths are relative to the
    # .blend file, as Blender's own: never to the folder Blender happened to be started in.
    directory = os.path.expanduser(directory.strip()) or DEFAULT_DIRECTORY
    if not directory.startswith("//") and not os.path.isabs(directory):
        directory = "//" + directory
    if directory.startswith("//") and not bpy.data.filepath:
        warning = ("the .blend file is not saved: the caches are in Blender's temporary folder, deleted when "
                   "Blender quits (save the file and bake again to keep them)")
        directory = bpy.app.tempdir
    # Every other base keeps its folder: the one its last bake gave it, else the one it would get.
    others = [o.gshell.cache_name or bpy.path.clean_name(o.name) for o in bpy.data.objects
              if o.gshell.role == "BASE" and o != base]
    name = cache_names([base], others)[0]
    return os.path.join(bpy.path.abspath(directory), name), name, warning


def frame_ranges(frames):
    """Ascending frame numbers as "frames 3-5, 9" ("frame 3" for one)."""
    runs = []
    for f in frames:
        if runs and f == runs[-1][1] + 1:
            runs[-1][1] = f
        else:
            runs.append([f, f])
    text = ", ".join(str(a) if a == b else f"{a}-{b}" if a >= 0 else f"{a} to {b}" for a, b in runs)
    return ("frame " if len(frames) == 1 else "frames ") + text


def _same_placement(a, b):
    """Whether two object-to-base matrices agree (the bind matrix is stored in float32)."""
    scale = max(abs(b[i][j]) for i in range(4) for j in range(4))
    return all(abs(a[i][j] - b[i][j]) <= 1e-5 * (1 + scale) for i in range(4) for j in range(4))


class Bake:
    """One bake: the rest shell and embeddings prepared once, then step() solves one frame."""

    def __init__(self, gshell, context, base, frame_start, frame_end, directory, allow_invalid=False):
        if frame_end < frame_start:
            raise shell_store.ShellError(f"frame_end ({frame_end}) is before frame_start ({frame_start})")
        self.scene = context.scene
        self.base = base
        self.top = shell_store.top_of(base)
        self.frames = list(range(frame_start, frame_end + 1))
        self.frame_before = self.scene.frame_current
        shell = shell_store.rest_shell(gshell, base)
        self.n = len(shell.base)
        # Assembles and factors the system once. Every frame is valid (certified) unless
        # allow_invalid: the paper's unguarded frames, as `gshell deform --allow-invalid`.
        self.allow_invalid = allow_invalid
        self.deformer = gshell.Deformer(shell, allow_invalid=True) if allow_invalid else gshell.Deformer(shell)
        self.details = [d for d in shell_store.details_of(base, self.scene) if len(d.data.vertices)]
        # Where each detail is now in the base's space. A detail moved since it was bound (or a copy of
        # one, Shift+D, which carries its bind matrix) is carried from where it is: the bind matrix
        # alone would give it the motion of the place it was bound at, off the shell.
        to_base = shell_store.inverted(base, base.matrix_world)
        self.placements = [to_base @ d.matrix_world for d in self.details]
        self.moved = [not _same_placement(m, d.gshell.bind_matrix) for d, m in zip(self.details, self.placements)]
        # Checked before anything is written, naming the detail (one that changed since it was bound).
        embedded = [shell_store.embed_detail(gshell, shell, d, m) for d, m in zip(self.details, self.placements)]
        self.embeddings = [embedding for embedding, _ in embedded]
        self.to_detail = [back for _, back in embedded]
        self.objects = [self.top] + self.details
        self.folder, folder_name, self.warning = cache_directory(base, directory)
        # The bake sees what the viewport shows: a deformer off there but on for render moves the base in
        # a render and not the shell. (Off in the viewport is how a topology-changing one must be baked.)
        render_only = [m.name for m in base.modifiers
                       if m.show_render and not m.show_viewport and m.type in _DEFORM_ONLY]
        if render_only:
            self.warning = "; ".join(filter(None, [self.warning, (
                f"modifiers of '{base.name}' that are on for render but off in the viewport are left out of the "
                f"bake, which follows the viewport: {', '.join(render_only)}")]))
        # Distinct names, so distinct files: kept on the objects only when the bake completes.
        self.names = [folder_name] + cache_names(self.objects)
        self.writers = []
        try:
            for obj, name in zip(self.objects, self.names[1:]):
                path = point_cache.next_version_path(self.folder, name)
                self.writers.append(point_cache.PointCacheWriter(path, len(obj.data.vertices), frame_start,
                                                                 len(self.frames)))
        except OSError as e:
            self.cancel()
            raise shell_store.ShellError(f"cannot write the cache: {e}") from e
        # Earlier caches of these objects would be evaluated at every frame for nothing.
        self.muted = [m for m in (o.modifiers.get(point_cache.MODIFIER_NAME) for o in self.objects)
                      if m is not None and m.show_viewport]
        for modifier in self.muted:
            modifier.show_viewport = False
        self.done = 0
        self.frame_stats = []

    def step(self):
        """Bakes the next frame; True when every frame is done."""
        clock = [time.perf_counter()]

        def lap():
            clock.append(time.perf_counter())
            return clock[-1] - clock[-2]

        frame = self.frames[self.done]
        self.scene.frame_set(frame)
        V = evaluated_base_positions(self.base, bpy.context.evaluated_depsgraph_get(), self.n)
        evaluate = lap()
        top = self.deformer.solve(V)
        X = self.deformer.vertices
        solve = lap()
        carried = [e.carry(X) for e in self.embeddings]
        carry = lap()
        self.writers[0].write(top)
        for to_detail, P, writer in zip(self.to_detail, carried, self.writers[1:]):
            writer.write(shell_store.transform(to_detail, P))
        write = lap()
        last = self.deformer.last
        self.frame_stats.append({
            "frame": frame, "iterations": last["iterations"], "converged": last["converged"],
            "stretch_max": last["stretch"]["max"], "inverted_tets": last["inverted_tets"],
            "valid": last.get("valid"), "method": last.get("method"),
            "base_self_intersections": last.get("base_self_intersections"),
            "seconds": {"total": clock[-1] - clock[0], "evaluate": evaluate, "solve": solve, "carry": carry,
                        "write": write}})
        self.done += 1
        return self.done == len(self.frames)

    def finish(self):
        """Puts the caches in place and attaches them; returns (level, status line): a WARNING that
        names the frames a guarded bake could not keep valid, and why."""
        try:
            point_cache.commit_all(self.writers, self.names[1:], point_cache.playing_paths())
        except point_cache.CommitError as e:
            raise shell_store.ShellError(f"'{self.objects[e.index].name}': {e}") from e
        for obj, name in zip([self.base] + self.objects, self.names):
            obj.gshell.cache_name = name
        # Bound inside a shell generated again since, thinner, say: Bind warned of those outside then.
        strayed = [f"'{d.name}' {len(e.outside)} (at binding {d[shell_store.OUTSIDE_KEY]})"
                   for d, e, moved in zip(self.details, self.embeddings, self.moved)
                   if not moved and len(e.outside) > d.get(shell_store.OUTSIDE_KEY, len(e.outside))]
        for d, placement, embedding, moved in zip(self.details, self.placements, self.embeddings, self.moved):
            if moved:  # bound again where it is
                d.gshell.bind_matrix = placement
                d[shell_store.OUTSIDE_KEY] = len(embedding.outside)
        for obj, writer in zip(self.objects, self.writers):
            point_cache.attach(obj, writer.path, self.frames[0]).show_viewport = True
        self.scene.frame_set(self.frame_before)
        seconds = sorted(s["seconds"]["total"] for s in self.frame_stats)
        per_frame = seconds[len(seconds) // 2]
        worst = max(s["stretch_max"] for s in self.frame_stats)
        inverted = max(s["inverted_tets"] for s in self.frame_stats)
        invalid = sum(1 for s in self.frame_stats if s["valid"] is False)
        self.top[shell_store.BAKE_REPORT_KEY] = json.dumps({
            "frame_start": self.frames[0], "frame_end": self.frames[-1], "vertices": self.n,
            "details": [d.name for d in self.details], "directory": self.folder,
            "factor_seconds": self.deformer.factor_seconds, "median_seconds_per_frame": per_frame,
            "allow_invalid": self.allow_invalid, "invalid_frames": invalid,
            "frames": self.frame_stats}, separators=(",", ":"))  # kept in the .blend: compact
        line = (f"gshell: baked {frame_ranges(self.frames)} of '{self.base.name}' (top and "
                f"{len(self.details)} detail object(s)): {per_frame:.3g} s per frame, max stretch {worst:.3g}, "
                f"{'no' if inverted == 0 else 'up to ' + str(inverted)} inverted tets, "
                f"{invalid} invalid frame(s){' (allow invalid)' if self.allow_invalid else ''}; caches in {self.folder}")
        moved = [f"'{d.name}'" for d, m in zip(self.details, self.moved) if m]
        if moved:
            line += f"; moved since bound, carried from where they are now (bound there): {', '.join(moved)}"
        if strayed:
            line += (f"; more detail vertices than at binding lie outside the shell (it was generated again since?) "
                     f"and follow the nearest tet: {', '.join(strayed)}")
        if not invalid or self.allow_invalid:
            return ("WARNING" if strayed else "INFO"), line
        bad = [s for s in self.frame_stats if s["valid"] is False]
        crossing = max((s["base_self_intersections"] or 0) for s in bad)
        why = (f"the animated base intersects itself there (up to {crossing} face pairs): no shell over it can be "
               f"valid" if crossing else "the guard could not keep them valid (per frame: the top's gshell_bake)")
        return "WARNING", f"{line}. Not valid: {frame_ranges([s['frame'] for s in bad])}: {why}"

    def cancel(self):
        for writer in self.writers:
            writer.discard()
        for modifier in getattr(self, "muted", []):
            modifier.show_viewport = True
        self.scene.frame_set(self.frame_before)


class OBJECT_OT_gshell_bake(bpy.types.Operator):
    """Bake the active object's shell and its bound detail over a frame range (Esc cancels)"""
    bl_idname = "object.gshell_bake"
    bl_label = "Bake Shell"
    bl_options = {"REGISTER", "UNDO"}

    frame_start: bpy.props.IntProperty(name="Start", description="First frame to bake (default: the scene's)")
    frame_end: bpy.props.IntProperty(name="End", description="Last frame to bake (default: the scene's)")
    directory: bpy.props.StringProperty(
        name="Cache folder", default=DEFAULT_DIRECTORY, subtype="DIR_PATH",
        description="Where the point caches go (one sub-folder per base); '//' is the .blend file's folder")
    allow_invalid: bpy.props.BoolProperty(
        name="Allow invalid", default=False,
        description="Skip the guard and bake the unguarded frames (tets may invert, the shell may pass through "
                    "itself), as gshell deform --allow-invalid; by default every frame is valid")

    @classmethod
    def poll(cls, context):
        return shell_store.base_of(context.active_object) is not None

    def _start(self, context):
        for name in ("frame_start", "frame_end"):
            if not self.properties.is_property_set(name):
                setattr(self, name, getattr(context.scene, name))
        base = shell_store.base_of(context.active_object)
        shell_store.flush_edits(context)
        try:
            self._bake = Bake(gshell_module.get(), context, base, self.frame_start, self.frame_end, self.directory,
                              self.allow_invalid)
        except (gshell_module.ModuleUnavailable, shell_store.ShellError, ValueError) as e:
            self.report({"ERROR"}, f"gshell: {e}")
            return False
        if self._bake.warning:
            self.report({"WARNING"}, f"gshell: {self._bake.warning}")
        return True

    def _step(self):
        """One frame; on an error the bake is dropped and reported. Returns 'more', 'done' or 'failed'."""
        try:
            return "done" if self._bake.step() else "more"
        except (shell_store.ShellError, ValueError, OSError) as e:
            self._bake.cancel()
            self.report({"ERROR"}, f"gshell: {e}; nothing was baked")
            return "failed"

    def _finish(self):
        try:
            level, line = self._bake.finish()
            self.report({level}, line)
        except shell_store.ShellError as e:  # says what became of the earlier caches
            self._bake.cancel()
            self.report({"ERROR"}, f"gshell: {e}")
            return {"CANCELLED"}
        return {"FINISHED"}

    def execute(self, context):
        """Bakes every frame before returning (scripts, background mode)."""
        if not self._start(context):
            return {"CANCELLED"}
        count = len(self._bake.frames)
        wm = context.window_manager
        wm.progress_begin(0, count)
        printed = time.perf_counter()
        try:
            while True:
                state = self._step()
                wm.progress_update(self._bake.done)
                if bpy.app.background and (state == "done" or time.perf_counter() - printed > 1.0):
                    printed = time.perf_counter()  # no window to show progress: a line a second
                    print(f"gshell bake: '{self._bake.base.name}' frame {self._bake.done}/{count}", file=sys.stderr)
                if state == "failed":
                    return {"CANCELLED"}
                if state == "done":
                    return self._finish()
        finally:
            wm.progress_end()

    def invoke(self, context, event):
        """Bakes one frame per timer tick, so the interface shows progress and Esc cancels."""
        if not self._start(context):
            return {"CANCELLED"}
        wm = context.window_manager
        wm.progress_begin(0, len(self._bake.frames))
        self._timer = wm.event_timer_add(0.001, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC":
            self._bake.cancel()
            self._end(context)
            self.report({"WARNING"}, "gshell: bake cancelled; nothing was written")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"RUNNING_MODAL"}  # the scene must not change under the bake
        state = self._step()
        context.window_manager.progress_update(self._bake.done)
        context.workspace.status_text_set(
            f"gshell: baking '{self._bake.base.name}', frame {self._bake.done}/{len(self._bake.frames)}; Esc cancels")
        if state == "more":
            return {"RUNNING_MODAL"}
        self._end(context)
        return self._finish() if state == "done" else {"CANCELLED"}

    def _end(self, context):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
