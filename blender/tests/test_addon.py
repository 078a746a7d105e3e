"""Tests of the gshell Blender add-on, run inside Blender in the background with a fresh user profile:

    blender/headless/run blender/tests/test_addon.py build/gshell_blender.zip     (CTest: blender_addon)

The zip is installed and enabled the way a user does it (Preferences > Add-ons > Install...), then:
the top of a quad UV sphere equals the Python module's shell of the same mesh cut into triangles;
a baked bend carries the top (about the thickness above the base, equal to gshell.Deformer fed the
same base positions) and the bound detail (equal to embed().carry in world space); meshes the
module rejects (non-manifold, degenerate) and topology-changing modifiers give an error and change
nothing, as do details Bind cannot carry (flattened, non-finite); objects and bases whose clean names
clash bake to caches of their own; a bake's caches are all put in place or none; an undone re-bake
plays its own cache; a detail moved after binding is carried from where it is; the top keeps the
base's UV maps and materials; a linked base is refused and an override keeps its shell.
"""
import json
import math
import os
import pathlib
import sys
import tempfile
import unittest

import numpy as np

import bpy
from mathutils import Euler, Vector

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "headless"))
import addon_session  # noqa: E402 (blender/headless/addon_session.py)

THICKNESS_RATIO = 0.05


def the_module():
    """The gshell module as the add-on loads it (the copy carried in the zip)."""
    import gshell_blender
    return gshell_blender.gshell_module.get()


def positions(mesh):
    return np.array([v.co[:] for v in mesh.vertices], dtype=np.float64)


def evaluated_positions(obj):
    """Local vertex positions after modifiers (the Mesh Cache playback included) at the current frame."""
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    try:
        return positions(mesh)
    finally:
        evaluated.to_mesh_clear()


def to_world(obj_matrix, P):
    A = np.array(obj_matrix)
    return P @ A[:3, :3].T + A[:3, 3]


def fan_triangles(mesh):
    """Each polygon cut into a fan from its first corner, winding kept (for quads: 0-1-2, 0-2-3)."""
    F = []
    for polygon in mesh.polygons:
        v = list(polygon.vertices)
        F += [(v[0], v[i], v[i + 1]) for i in range(1, len(v) - 1)]
    return np.array(F, dtype=np.int64)


def uv_sphere(name="Sphere", segments=24, rings=12):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=rings, radius=1.0)
    obj = bpy.context.active_object
    obj.name = name
    return obj


def bounding_radius(V):
    centre = 0.5 * (V.min(axis=0) + V.max(axis=0))
    return np.linalg.norm(V - centre, axis=1).max()


def shell_and_ball(direction=(1, 0, 0)):
    """A 12 x 6 UV sphere with its shell, and a ball of radius 0.01 halfway up its layer along `direction`."""
    sphere = uv_sphere(segments=12, rings=6)
    bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
    eta = sphere.gshell.top.gshell.thickness
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1, radius=0.01, location=Vector(direction) * (1 + 0.5 * eta))
    return sphere, bpy.context.active_object


class AddonTest(unittest.TestCase):
    def setUp(self):
        for obj in list(bpy.data.objects):
            bpy.data.objects.remove(obj)
        for mesh in list(bpy.data.meshes):
            bpy.data.meshes.remove(mesh)
        bpy.context.scene.frame_set(1)

    def test_installed_from_the_zip(self):
        gshell = the_module()
        import gshell_blender
        profile = os.environ["BLENDER_USER_SCRIPTS"]
        self.assertTrue(gshell_blender.__file__.startswith(profile), gshell_blender.__file__)
        self.assertTrue(gshell.__file__.startswith(os.path.join(profile, "addons", "gshell_blender", "lib")),
                        gshell.__file__)

    def test_sidebar_tab_offers_the_operators(self):
        from unittest import mock
        panel = bpy.types.VIEW3D_PT_gshell
        self.assertEqual((panel.bl_space_type, panel.bl_region_type, panel.bl_category), ("VIEW_3D", "UI", "gshell"))
        uv_sphere(segments=8, rings=4)
        bpy.ops.object.gshell_generate()
        fake = mock.MagicMock()  # records the layout calls
        panel.draw(fake, bpy.context)
        drawn = str(fake.layout.mock_calls)
        for operator in ("object.gshell_generate", "object.gshell_bind", "object.gshell_unbind", "object.gshell_bake"):
            self.assertIn(operator, drawn)

    def test_top_of_quad_sphere_equals_module_shell(self):
        gshell = the_module()
        sphere = uv_sphere()
        sphere.location = (0.5, -1.0, 2.0)
        sphere.rotation_euler = Euler((0.3, 0.2, 1.0))
        sphere.scale = (2.0, 2.0, 2.0)
        bpy.context.view_layer.update()
        self.assertGreater(sum(len(p.vertices) == 4 for p in sphere.data.polygons), 200)

        result = bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO, method="rigid")
        self.assertEqual(result, {"FINISHED"})
        top = bpy.data.objects["Sphere.top"]
        bpy.context.view_layer.update()

        V = positions(sphere.data)
        F = fan_triangles(sphere.data)
        expected = gshell.generate(V, F, thickness_ratio=THICKNESS_RATIO, method="rigid")
        T = positions(top.data)
        self.assertEqual(T.shape, V.shape)
        np.testing.assert_allclose(T, expected.top, atol=1e-6)  # float32 storage of coordinates ~1
        np.testing.assert_array_equal(np.asarray(top["gshell_faces"]).reshape(-1, 3), F)
        self.assertAlmostEqual(top.gshell.thickness, expected.thickness, places=6)
        self.assertEqual(json.loads(top["gshell_report"])["certificate"]["inverted_tets"], 0)
        # The ratio typed, not its single-precision neighbour 0.05000000074505806.
        self.assertEqual(json.loads(top["gshell_report"])["thickness"]["ratio"], THICKNESS_RATIO)
        # the top is the same surface over the same vertices, with the same transform
        self.assertEqual([tuple(p.vertices) for p in top.data.polygons],
                         [tuple(p.vertices) for p in sphere.data.polygons])
        np.testing.assert_allclose(np.array(top.matrix_world), np.array(sphere.matrix_world), atol=1e-6)
        # about eta outside the base (unit sphere: the offset is radial)
        eta = THICKNESS_RATIO * bounding_radius(V)
        offset = np.einsum("ij,ij->i", T - V, V / np.linalg.norm(V, axis=1)[:, None])
        self.assertGreater(offset.min(), 0.9 * eta)
        self.assertLess(offset.max(), 1.1 * eta)

    def test_bake_carries_top_and_bound_detail(self):
        gshell = the_module()
        sphere = uv_sphere()
        sphere.location = (0.0, 0.0, 1.0)
        bpy.context.view_layer.update()
        bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
        top = sphere.gshell.top
        eta = top.gshell.thickness
        rest_top = positions(top.data)

        # Two small details inside the layer, one with its own rotation and scale.
        details = []
        for direction, rotation, scale in (((1, 0, 0.3), (0, 0, 0), 1.0), ((-0.2, 0.6, -0.7), (0.5, 1.0, 0.2), 0.5)):
            d = Vector(direction).normalized()
            bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1, radius=0.015 / scale,
                                                  location=Vector(sphere.location) + d * (1 + 0.5 * eta))
            obj = bpy.context.active_object
            obj.rotation_euler = Euler(rotation)
            obj.scale = (scale, scale, scale)
            details.append(obj)
        bpy.context.view_layer.update()
        rest_world = [to_world(d.matrix_world, positions(d.data)) for d in details]
        addon_session.select(details + [sphere], sphere)
        self.assertEqual(bpy.ops.object.gshell_bind(), {"FINISHED"})
        self.assertTrue(all(d.gshell.role == "DETAIL" and d.parent == sphere for d in details))

        addon_session.animate_bend(sphere, 90, 1, 8)
        self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=8), {"FINISHED"})
        self.assertEqual(bpy.context.scene.frame_current, 1)
        np.testing.assert_array_equal(positions(top.data), rest_top)  # the rest top is kept

        # The same frames through the module directly, in the same order (each frame starts from the last).
        V_rest = positions(sphere.data)
        shell = gshell.Shell(V_rest, np.asarray(top["gshell_faces"]).reshape(-1, 3), rest_top, eta)
        deformer = gshell.Deformer(shell)
        to_base = np.array(sphere.matrix_world.inverted())
        embeddings = [gshell.embed(shell, to_world(to_base, P)) for P in rest_world]
        moved = {}
        for frame in range(1, 9):
            bpy.context.scene.frame_set(frame)
            base = evaluated_positions(sphere)
            new_top = deformer.solve(base)
            carried = [to_world(sphere.matrix_world, e.carry(deformer.vertices)) for e in embeddings]
            if frame not in (2, 5, 8):
                continue
            baked_top = evaluated_positions(top)
            np.testing.assert_allclose(baked_top, new_top, atol=1e-5, err_msg=f"top at frame {frame}")
            # The top stays about eta above the bent base, on the outside.
            normals = np.array([v.normal[:] for v in sphere.evaluated_get(
                bpy.context.evaluated_depsgraph_get()).data.vertices])
            height = np.einsum("ij,ij->i", baked_top - base, normals)
            self.assertGreater(height.min(), 0.7 * eta, f"frame {frame}")
            self.assertLess(height.max(), 1.3 * eta, f"frame {frame}")
            self.assertAlmostEqual(float(np.median(height)), eta, delta=0.1 * eta)
            for d, expected in zip(details, carried):
                baked = to_world(d.matrix_world, evaluated_positions(d))
                np.testing.assert_allclose(baked, expected, atol=1e-5, err_msg=f"{d.name} at frame {frame}")
            moved[frame] = (baked_top, [to_world(d.matrix_world, evaluated_positions(d)) for d in details])
        # The bend really moved the shell and the detail.
        self.assertGreater(np.abs(moved[8][0] - moved[2][0]).max(), 0.3)
        for a, b in zip(moved[8][1], moved[2][1]):
            self.assertGreater(np.linalg.norm(a - b, axis=1).min(), 0.02)

        # Baking again (the first bake's caches are playing meanwhile) gives the same motion.
        self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=8), {"FINISHED"})
        self.assertTrue(top.modifiers["gshell bake"].show_viewport)
        bpy.context.scene.frame_set(8)
        np.testing.assert_array_equal(evaluated_positions(top), moved[8][0])

        # Unbinding releases a detail and removes its baked motion.
        addon_session.select(details[:1], details[0])
        self.assertEqual(bpy.ops.object.gshell_unbind(), {"FINISHED"})
        self.assertEqual(details[0].gshell.role, "NONE")
        self.assertNotIn("gshell bake", details[0].modifiers)
        self.assertIn("gshell bake", details[1].modifiers)

    def test_bake_allow_invalid_gives_the_unguarded_frames(self):
        gshell = the_module()
        sphere = uv_sphere(segments=12, rings=6)
        bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
        top = sphere.gshell.top
        addon_session.animate_bend(sphere, 90, 1, 4)
        self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=4), {"FINISHED"})
        report = json.loads(top["gshell_bake"])
        self.assertFalse(report["allow_invalid"])
        self.assertTrue(all(f["valid"] and f["method"] in ("bounded", "guarded") for f in report["frames"]))
        self.assertEqual(report["invalid_frames"], 0)
        self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=4, allow_invalid=True), {"FINISHED"})
        report = json.loads(top["gshell_bake"])
        self.assertTrue(report["allow_invalid"])
        self.assertEqual({f["method"] for f in report["frames"]}, {"unguarded"})
        # The frames of the module's unguarded Deformer fed the same bases.
        shell = gshell.Shell(positions(sphere.data), np.asarray(top["gshell_faces"]).reshape(-1, 3),
                             positions(top.data), top.gshell.thickness)
        deformer = gshell.Deformer(shell, allow_invalid=True)
        for frame in range(1, 5):
            bpy.context.scene.frame_set(frame)
            expected = deformer.solve(evaluated_positions(sphere))
            np.testing.assert_allclose(evaluated_positions(top), expected, atol=1e-5, err_msg=f"frame {frame}")

    def test_a_bake_with_invalid_frames_warns_naming_them_and_why(self):
        from gshell_blender import op_bake
        self.assertEqual(op_bake.frame_ranges([3, 4, 5, 9]), "frames 3-5, 9")
        self.assertEqual(op_bake.frame_ranges([2]), "frame 2")
        sphere = uv_sphere(segments=12, rings=6)
        bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
        addon_session.animate_bend(sphere, 270, 1, 4)  # the bent sphere runs into itself
        bake = op_bake.Bake(the_module(), bpy.context, sphere, 1, 4, op_bake.DEFAULT_DIRECTORY)
        while not bake.step():
            pass
        level, line = bake.finish()
        invalid = [s["frame"] for s in json.loads(sphere.gshell.top["gshell_bake"])["frames"] if s["valid"] is False]
        self.assertTrue(invalid)
        self.assertEqual(level, "WARNING")
        self.assertIn(f"Not valid: {op_bake.frame_ranges(invalid)}: the animated base intersects itself", line)

    def test_a_top_whose_base_is_gone_is_a_plain_mesh_again(self):
        sphere = uv_sphere(segments=12, rings=6)
        bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
        top = sphere.gshell.top
        bpy.data.objects.remove(sphere)
        addon_session.select([top], top)
        self.assertEqual(bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO), {"FINISHED"})
        self.assertEqual(top.gshell.role, "BASE")

    def test_bake_of_a_saved_file_is_kept_next_to_it(self):
        import gshell_blender
        # Later tests want an unsaved file again: the folder saved to here is deleted.
        self.addCleanup(bpy.ops.wm.read_homefile, use_empty=True)
        sphere = uv_sphere(segments=12, rings=6)
        bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
        addon_session.animate_bend(sphere, 60, 1, 4)
        with tempfile.TemporaryDirectory() as folder:
            blend = os.path.join(folder, "scene.blend")
            bpy.ops.wm.save_as_mainfile(filepath=blend)
            self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=4), {"FINISHED"})
            top = sphere.gshell.top
            modifier = top.modifiers["gshell bake"]
            self.assertEqual(modifier.filepath, "//gshell_cache/Sphere/Sphere_top.pc2")
            self.assertEqual(os.listdir(os.path.join(folder, "gshell_cache", "Sphere")), ["Sphere_top.pc2"])
            start, samples = gshell_blender.point_cache.read(bpy.path.abspath(modifier.filepath))
            self.assertEqual((start, samples.shape), (1.0, (4, len(sphere.data.vertices), 3)))
            bpy.context.scene.frame_set(3)
            played = evaluated_positions(top)
            np.testing.assert_allclose(played, samples[2], atol=1e-6)
            bpy.ops.wm.save_mainfile()

            bpy.ops.wm.open_mainfile(filepath=blend)
            top = bpy.data.objects["Sphere.top"]
            self.assertEqual(top.gshell.base, bpy.data.objects["Sphere"])
            bpy.context.scene.frame_set(3)
            np.testing.assert_allclose(evaluated_positions(top), played, atol=1e-6)

    def test_topology_changing_modifier_is_an_error(self):
        sphere = uv_sphere(segments=12, rings=6)
        bpy.ops.object.gshell_generate(thickness_mode="ABSOLUTE", thickness=0.07)
        top = sphere.gshell.top
        self.assertAlmostEqual(top.gshell.thickness, 0.07, places=6)
        subdivision = sphere.modifiers.new("Subdivision", "SUBSURF")
        with self.assertRaises(RuntimeError) as error:
            bpy.ops.object.gshell_bake(frame_start=1, frame_end=3)
        self.assertIn("Subdivision", str(error.exception))
        self.assertIn("vertices", str(error.exception))
        self.assertEqual(len(top.modifiers), 0)
        # The bake evaluates the viewport's stack: hidden there, the modifier is no obstacle.
        subdivision.show_viewport = False
        self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=3), {"FINISHED"})
        self.assertIn("gshell bake", top.modifiers)

    def test_bind_refuses_a_flattened_or_unembeddable_detail_and_changes_nothing(self):
        sphere, good = shell_and_ball()
        eta = sphere.gshell.top.gshell.thickness
        bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1, radius=0.01, location=(0, 1 + 0.5 * eta, 0))
        flat = bpy.context.active_object
        flat.scale = (1, 1, 0)  # its world matrix has no inverse: carried points could not go back to it
        mesh = bpy.data.meshes.new("nan")
        mesh.from_pydata([(0, 0, 1 + 0.5 * eta)], [], [])
        mesh.vertices[0].co.x = float("nan")
        unembeddable = bpy.data.objects.new("nan", mesh)
        bpy.context.collection.objects.link(unembeddable)
        bpy.context.view_layer.update()
        for refused, words in ((flat, ["flattened", "scale of 0"]), (unembeddable, ["not finite"])):
            addon_session.select([good, refused], sphere)
            with self.assertRaises(RuntimeError) as error:
                bpy.ops.object.gshell_bind()
            for word in [f"'{refused.name}'"] + words:
                self.assertIn(word, str(error.exception))
            for obj in (good, refused):  # neither is bound, not even the good one
                self.assertEqual((obj.gshell.role, obj.gshell.base, obj.parent), ("NONE", None, None), obj.name)

        # The good one alone binds and bakes; edited past embedding afterwards, the bake names it.
        addon_session.select([good], sphere)
        self.assertEqual(bpy.ops.object.gshell_bind(), {"FINISHED"})
        addon_session.animate_bend(sphere, 60, 1, 2)
        self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=2), {"FINISHED"})
        good.data.vertices[0].co.y = float("nan")
        with self.assertRaises(RuntimeError) as error:
            bpy.ops.object.gshell_bake(frame_start=1, frame_end=2)
        self.assertIn(f"'{good.name}'", str(error.exception))
        self.assertIn("not finite", str(error.exception))

    def played_cache(self, obj, frame):
        """obj's evaluated vertices at frame, checked to be its own cache file's sample (right size)."""
        import gshell_blender
        start, samples = gshell_blender.point_cache.read(bpy.path.abspath(obj.modifiers["gshell bake"].filepath))
        self.assertEqual(samples.shape[1], len(obj.data.vertices), obj.name)
        bpy.context.scene.frame_set(frame)
        played = evaluated_positions(obj)
        np.testing.assert_allclose(played, samples[frame - int(start)], atol=1e-6, err_msg=obj.name)
        return played

    def test_bake_gives_details_whose_clean_names_clash_caches_of_their_own(self):
        sphere = uv_sphere(segments=12, rings=6)
        bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
        eta = sphere.gshell.top.gshell.thickness
        bend = addon_session.animate_bend(sphere, 90, 1, 4)
        balls = []
        with tempfile.TemporaryDirectory() as folder:
            # 'ball 1' and 'ball_1' are both ball_1 to bpy.path.clean_name; the second comes after a bake.
            for name, subdivisions, direction, degrees in (("ball 1", 1, (0, 0.6, 0.8), 90),
                                                           ("ball_1", 2, (0, -0.6, 0.8), 140)):
                bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=subdivisions, radius=0.01,
                                                      location=Vector(direction) * (1 + 0.5 * eta))
                balls.append(bpy.context.active_object)
                balls[-1].name = name
                addon_session.select(balls[-1:], sphere)
                self.assertEqual(bpy.ops.object.gshell_bind(), {"FINISHED"})
                bend.angle = math.radians(degrees)  # the second bake replaces a different motion
                bend.keyframe_insert("angle", frame=4)
                self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=4, directory=folder + "/"),
                                 {"FINISHED"})
            self.assertEqual([os.path.basename(b.modifiers["gshell bake"].filepath) for b in balls],
                             ["ball_1.bake2.pc2", "ball_1.001.pc2"])  # the first keeps its name (baked again)
            for ball in balls:
                rest = positions(ball.data)
                self.assertGreater(np.linalg.norm(self.played_cache(ball, 4) - rest, axis=1).min(), 0.05, ball.name)

    def test_bake_gives_bases_whose_clean_names_clash_folders_of_their_own(self):
        bases = []
        for name, x, degrees in (("Tube 1", 0, 90), ("Tube_1", 5, -60)):
            base = uv_sphere(name, segments=12, rings=6)
            base.location.x = x
            bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
            addon_session.animate_bend(base, degrees, 1, 4)
            bases.append(base)
        with tempfile.TemporaryDirectory() as folder:
            for base in bases:
                addon_session.select([base], base)
                self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=4, directory=folder + "/"),
                                 {"FINISHED"})
            self.assertEqual(sorted(os.listdir(folder)), ["Tube_1", "Tube_1.001"])
            paths = [bpy.path.abspath(b.gshell.top.modifiers["gshell bake"].filepath) for b in bases]
            self.assertNotEqual(paths[0], paths[1])
            second = pathlib.Path(paths[1]).read_bytes()
            addon_session.select(bases[:1], bases[0])  # baked again, the first keeps its folder
            self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=4, directory=folder + "/"),
                             {"FINISHED"})
            self.assertEqual(os.path.dirname(bpy.path.abspath(bases[0].gshell.top.modifiers["gshell bake"].filepath)),
                             os.path.dirname(paths[0]))
            self.assertEqual(pathlib.Path(paths[1]).read_bytes(), second)
            for base in bases:  # each top follows its own base's bend, about eta above it
                top = base.gshell.top
                gap = np.linalg.norm(self.played_cache(top, 4) - evaluated_positions(base), axis=1)
                self.assertLess(gap.max(), 2 * top.gshell.thickness, base.name)

    def test_bake_puts_every_cache_in_place_or_none(self):
        from unittest import mock
        sphere = uv_sphere(segments=12, rings=6)
        bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
        top = sphere.gshell.top
        bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1, radius=0.01,
                                              location=(1 + 0.5 * top.gshell.thickness, 0, 0))
        ball = bpy.context.active_object
        addon_session.select([ball], sphere)
        bpy.ops.object.gshell_bind()
        bend = addon_session.animate_bend(sphere, 60, 1, 3)
        with tempfile.TemporaryDirectory() as folder:
            self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=3, directory=folder + "/"),
                             {"FINISHED"})
            paths = [bpy.path.abspath(o.modifiers["gshell bake"].filepath) for o in (top, ball)]
            before = [pathlib.Path(p).read_bytes() for p in paths]
            bend.angle = -1.0
            bend.keyframe_insert("angle", frame=3)
            replace = os.replace

            def refuse_the_ball(source, destination):  # the top's new cache goes in first, then this fails
                if os.path.basename(destination).startswith(ball.name) and source.endswith(".part"):
                    raise PermissionError(13, "Permission denied")
                return replace(source, destination)
            with mock.patch.object(os, "replace", refuse_the_ball), self.assertRaises(RuntimeError) as error:
                bpy.ops.object.gshell_bake(frame_start=1, frame_end=3, directory=folder + "/")
            for words in (f"'{ball.name}'", "Permission denied", "nothing was baked"):
                self.assertIn(words, str(error.exception))
            self.assertEqual([pathlib.Path(p).read_bytes() for p in paths], before)
            self.assertEqual(sorted(os.listdir(os.path.dirname(paths[0]))), sorted(map(os.path.basename, paths)))
            self.assertTrue(all(o.modifiers["gshell bake"].show_viewport for o in (top, ball)))

    def check_rejected(self, name, V, F, words):
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata(V, [], F)
        obj = bpy.data.objects.new(name, mesh)
        bpy.context.collection.objects.link(obj)
        addon_session.select([obj], obj)
        objects, meshes = set(bpy.data.objects), set(bpy.data.meshes)
        with self.assertRaises(RuntimeError) as error:
            bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
        for word in [name] + words:
            self.assertIn(word, str(error.exception))
        self.assertEqual(set(bpy.data.objects), objects)
        self.assertEqual(set(bpy.data.meshes), meshes)
        self.assertEqual(obj.gshell.role, "NONE")

    def test_non_manifold_mesh_is_an_error_and_creates_nothing(self):
        # three quads share the edge 0-1
        V = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (1, 0, 1), (0, 0, 1), (1, -1, 0), (0, -1, 0)]
        F = [(0, 1, 2, 3), (0, 1, 4, 5), (1, 0, 7, 6)]
        self.check_rejected("Fin", V, F, ["non-manifold", "edge (0, 1)"])

    def test_degenerate_face_is_an_error_and_creates_nothing(self):
        V = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0)]
        F = [(0, 1, 2), (0, 2, 3)]
        self.check_rejected("Sliver", V, F, ["zero area", "polygon 0"])

    def test_inconsistent_orientation_names_the_polygons(self):
        # A cube with its first quad flipped: the module numbers triangles, the user sees polygons.
        V = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
        F = [(0, 1, 2, 3), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7), (4, 5, 6, 7)]
        mesh = bpy.data.meshes.new("Mixed")
        mesh.from_pydata(V, [], F)
        obj = bpy.data.objects.new("Mixed", mesh)
        bpy.context.collection.objects.link(obj)
        addon_session.select([obj], obj)
        with self.assertRaises(RuntimeError) as error:
            bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
        message = str(error.exception)
        self.assertIn("oriented inconsistently", message)
        self.assertRegex(message, r"triangles \d+ and \d+ of polygons \d and \d")
        self.assertNotRegex(message, r"faces \d+ and \d+")

    def test_module_messages_are_put_in_blenders_terms(self):
        from gshell_blender.op_generate import for_blender
        polygon = [0, 0, 1, 1, 2, 2, 3]
        self.assertEqual(for_blender("mesh (V, F): vertex 8 is used by no face"), "vertex 8 is used by no face")
        self.assertEqual(for_blender("faces 1 and 3 use the same three vertices (0, 1, 2): a face is duplicated", polygon),
                         "triangles 1 and 3 of polygons 0 and 1 use the same three vertices (0, 1, 2): a face is duplicated")
        self.assertEqual(for_blender("faces 2 and 3 are oriented inconsistently", polygon),
                         "triangles 2 and 3 of polygon 1 are oriented inconsistently")
        self.assertEqual(for_blender("shared by 7 faces (0, 1, 2, 3, 4, 5, ...)", polygon),
                         "shared by 7 triangles (0, 1, 2, 3, 4, 5, ...) of polygons (0, 0, 1, 1, 2, 2, ...)")
        self.assertEqual(for_blender("face 9 (1, 2, 3) has zero area", polygon), "face 9 (1, 2, 3) has zero area")
        welded = for_blender("mesh (V, F): 4 edges ... seams; the shell gets walls along the cut; "
                             "`gshell convert --weld` joins them)")
        self.assertIn("Merge by Distance", welded)
        self.assertNotIn("gshell convert", welded)

    def test_generate_allow_invalid_gives_the_unguarded_shell(self):
        gshell = the_module()
        sphere = uv_sphere(segments=12, rings=6)
        self.assertEqual(bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO, allow_invalid=True),
                         {"FINISHED"})
        expected = gshell.generate(positions(sphere.data), np.asarray(sphere.gshell.top["gshell_faces"]).reshape(-1, 3),
                                   thickness_ratio=THICKNESS_RATIO, allow_invalid=True)
        np.testing.assert_allclose(positions(sphere.gshell.top.data), expected.top, atol=1e-6)

    def test_ngons_with_corners_on_a_line_are_cut_without_flat_triangles(self):
        # A cylinder's 24-gon caps cut 6 times: 168 corners, seven on each side's line. The
        # viewport's ear clipping made 73 flat triangles of them, which no prism can stand on.
        bpy.ops.mesh.primitive_cylinder_add(vertices=24, depth=4, end_fill_type="NGON")
        cylinder = bpy.context.active_object
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.mesh.subdivide(number_cuts=6)
        bpy.ops.object.mode_set(mode="OBJECT")
        from gshell_blender import mesh_arrays
        F, polygon = mesh_arrays.triangles(cylinder.data)
        sizes = [len(p.vertices) for p in cylinder.data.polygons]
        self.assertIn(168, sizes)
        self.assertEqual(len(F), sum(k - 2 for k in sizes))  # no vertex added
        self.assertTrue(np.all(np.diff(polygon) >= 0))
        for p in cylinder.data.polygons:  # every polygon cut into triangles of its own corners
            self.assertTrue(set(F[polygon == p.index].ravel()) <= set(p.vertices))
        V = positions(cylinder.data)
        doubled = np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
        self.assertGreater(doubled.min(), 1e-6)
        self.assertEqual(bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO), {"FINISHED"})
        self.assertEqual(json.loads(cylinder.gshell.top["gshell_report"])["certificate"]["inverted_tets"], 0)

    def test_a_mirror_is_not_an_uneven_scale(self):
        from gshell_blender import op_generate
        sphere = uv_sphere(segments=12, rings=6)
        for scale, expected in (((-1, 1, 1), (1, 1, 1)), ((-2, -2, -2), (2, 2, 2)), ((2, -3, 1), (2, 3, 1))):
            sphere.scale = scale
            bpy.context.view_layer.update()
            np.testing.assert_allclose(op_generate.axis_scales(sphere.matrix_world), expected, rtol=1e-6)

    def test_generate_offset_gives_the_modules_offset_shell(self):
        # The panel's iterations and allow_invalid do not apply to the offset, and the module
        # refuses them with it: the operator must leave them out, whatever their values.
        gshell = the_module()
        sphere = uv_sphere(segments=12, rings=6)
        self.assertEqual(bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO, method="offset",
                                                        iterations=3, allow_invalid=True), {"FINISHED"})
        expected = gshell.generate(positions(sphere.data), np.asarray(sphere.gshell.top["gshell_faces"]).reshape(-1, 3),
                                   thickness_ratio=THICKNESS_RATIO, method="offset")
        np.testing.assert_allclose(positions(sphere.gshell.top.data), expected.top, atol=1e-6)
        self.assertEqual(json.loads(sphere.gshell.top["gshell_report"])["method"], "offset")

    def test_bake_and_bind_in_edit_mode_see_the_edits(self):
        # A base edited in Edit Mode and not yet left: its mesh data lagged, so the bake's check that
        # the base is unchanged passed while its frames carried the edit (a top pulled out of shape).
        import bmesh
        sphere = uv_sphere(segments=12, rings=6)
        bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
        ball = bpy.data.objects.new("Ball", bpy.data.meshes.new("Ball"))
        bpy.context.collection.objects.link(ball)
        bpy.ops.object.mode_set(mode="EDIT")
        edit = bmesh.from_edit_mesh(sphere.data)
        edit.verts.ensure_lookup_table()
        edit.verts[5].co.x += 0.5
        bmesh.update_edit_mesh(sphere.data)
        with tempfile.TemporaryDirectory() as folder:
            with self.assertRaisesRegex(RuntimeError, "'Sphere' was changed since its shell was made"):
                bpy.ops.object.gshell_bake(frame_start=1, frame_end=2, directory=folder)
            self.assertEqual(os.listdir(folder), [])
        self.assertEqual(sphere.mode, "EDIT")
        ball.select_set(True)
        with self.assertRaisesRegex(RuntimeError, "'Sphere' was changed since its shell was made"):
            bpy.ops.object.gshell_bind()
        self.assertEqual(ball.gshell.role, "NONE")

    def test_generate_in_edit_mode_reads_the_edits_and_stays_in_edit_mode(self):
        sphere = uv_sphere(segments=12, rings=6)  # with a UV map, as Blender's primitives
        self.assertTrue(sphere.data.uv_layers)
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.transform.resize(value=(2, 2, 2))  # an edit not yet written to the mesh data
        self.assertEqual(bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO), {"FINISHED"})
        self.assertEqual(sphere.mode, "EDIT")
        bpy.ops.object.mode_set(mode="OBJECT")
        top = sphere.gshell.top
        self.assertGreater(np.linalg.norm(positions(sphere.data), axis=1).min(), 1.9)
        self.assertGreater(np.linalg.norm(positions(top.data), axis=1).min(), 2.0)
        self.assertEqual(len(top.data.uv_layers), len(sphere.data.uv_layers))
        self.assertEqual(sorted(m.name for m in bpy.data.meshes), sorted([sphere.data.name, top.data.name]))

    def test_generate_again_after_deleting_the_top_makes_a_visible_top(self):
        sphere = uv_sphere(segments=12, rings=6)
        bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
        top = sphere.gshell.top
        addon_session.select([top], top)
        bpy.ops.object.delete()
        addon_session.select([sphere], sphere)
        # A bake then has no top to carry (it wrote a cache for the deleted one and said it baked).
        with tempfile.TemporaryDirectory() as folder:
            with self.assertRaisesRegex(RuntimeError, "the top of 'Sphere' was deleted: run Generate Shell"):
                bpy.ops.object.gshell_bake(frame_start=1, frame_end=2, directory=folder)
            self.assertEqual(os.listdir(folder), [])
        self.assertEqual(bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO), {"FINISHED"})
        top = sphere.gshell.top
        self.assertIn(top.name, bpy.context.scene.objects)
        self.assertEqual(top.parent, sphere)

    def test_generate_again_drops_the_details_bakes_with_the_tops(self):
        sphere, detail = shell_and_ball()
        addon_session.select([detail, sphere], sphere)
        self.assertEqual(bpy.ops.object.gshell_bind(), {"FINISHED"})
        addon_session.animate_bend(sphere, 60, 1, 3)
        self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=3), {"FINISHED"})
        self.assertIn("gshell bake", detail.modifiers)
        addon_session.select([sphere], sphere)
        self.assertEqual(bpy.ops.object.gshell_generate(thickness_ratio=2 * THICKNESS_RATIO), {"FINISHED"})
        self.assertNotIn("gshell bake", sphere.gshell.top.modifiers)
        self.assertNotIn("gshell bake", detail.modifiers)  # it belonged to the old shell too
        # Generated again thinner, the detail now pokes out: the bake says so.
        from gshell_blender import op_bake
        self.assertEqual(bpy.ops.object.gshell_generate(thickness_ratio=0.2 * THICKNESS_RATIO), {"FINISHED"})
        bake = op_bake.Bake(the_module(), bpy.context, sphere, 1, 3, op_bake.DEFAULT_DIRECTORY)
        while not bake.step():
            pass
        level, line = bake.finish()
        self.assertEqual(level, "WARNING")
        self.assertRegex(line, rf"lie outside the shell .*'{detail.name}' \d+ \(at binding 0\)")

    def test_a_base_changed_since_generate_is_refused_until_generated_again(self):
        for change in ("edit", "apply scale"):
            with self.subTest(change=change):
                self.setUp()
                sphere = uv_sphere(segments=12, rings=6)
                sphere.scale = (2.0, 1.0, 1.0)
                bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
                if change == "edit":
                    sphere.data.vertices[0].co *= 1.2  # same vertex count
                else:
                    addon_session.select([sphere], sphere)
                    bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
                addon_session.animate_bend(sphere, 60, 1, 3)
                with self.assertRaises(RuntimeError) as error:
                    bpy.ops.object.gshell_bake(frame_start=1, frame_end=3)
                self.assertIn("run Generate Shell again", str(error.exception))
                self.assertNotIn("gshell bake", sphere.gshell.top.modifiers)
                addon_session.select([sphere], sphere)
                bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
                self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=3), {"FINISHED"})

    def test_bind_refuses_to_parent_a_detail_to_its_own_child(self):
        sphere, holder = shell_and_ball()
        sphere.parent = holder
        addon_session.select([holder, sphere], sphere)
        with self.assertRaises(RuntimeError) as error:
            bpy.ops.object.gshell_bind(parent=True)
        self.assertIn("is a parent of", str(error.exception))
        self.assertEqual(holder.gshell.role, "NONE")

    def test_bake_folder_empty_or_relative_is_never_the_working_folder(self):
        import gshell_blender
        sphere = uv_sphere(segments=8, rings=4)
        bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
        self.addCleanup(bpy.ops.wm.read_homefile, use_empty=True)
        with tempfile.TemporaryDirectory() as folder, tempfile.TemporaryDirectory() as cwd:
            bpy.ops.wm.save_as_mainfile(filepath=os.path.join(folder, "scene.blend"))
            before = os.getcwd()
            os.chdir(cwd)
            try:
                for directory, expected in (("", os.path.join(folder, "gshell_cache", "Sphere")),
                                            ("caches/", os.path.join(folder, "caches", "Sphere")),
                                            ("~/x/", os.path.join(os.path.expanduser("~"), "x", "Sphere"))):
                    self.assertEqual(gshell_blender.op_bake.cache_directory(sphere, directory)[0], expected)
            finally:
                os.chdir(before)


    def test_an_undone_rebake_plays_the_earlier_bakes_own_cache(self):
        # Re-baking wrote over the first bake's file: an undo brought back the first bake's modifier
        # (frames 1-10) playing the second bake's samples (frames 6-15), 5 frames off.
        self.addCleanup(bpy.ops.wm.read_homefile, use_empty=True)
        with tempfile.TemporaryDirectory() as folder:
            bpy.ops.wm.save_as_mainfile(filepath=os.path.join(folder, "scene.blend"))
            sphere = uv_sphere(segments=12, rings=6)
            bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
            bend = addon_session.animate_bend(sphere, 90, 1, 10)
            bpy.ops.ed.undo_push(message="generate")
            self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=10), {"FINISHED"})
            bpy.ops.ed.undo_push(message="bake 1")
            first = self.played_cache(sphere.gshell.top, 5)
            bend.angle = math.radians(-60)
            bend.keyframe_insert("angle", frame=10)
            self.assertEqual(bpy.ops.object.gshell_bake(frame_start=6, frame_end=15), {"FINISHED"})
            bpy.ops.ed.undo_push(message="bake 2")
            caches = os.path.join(folder, "gshell_cache", "Sphere")
            self.assertEqual(sorted(os.listdir(caches)), ["Sphere_top.bake2.pc2", "Sphere_top.pc2"])
            self.assertEqual(bpy.ops.ed.undo(), {"FINISHED"})
            top = bpy.data.objects["Sphere.top"]
            self.assertEqual(top.modifiers["gshell bake"].frame_start, 1)
            np.testing.assert_allclose(self.played_cache(top, 5), first, atol=1e-6)
            # Baking from there keeps the file now played (the next undo's) and drops the undone one.
            addon_session.select([bpy.data.objects["Sphere"]], bpy.data.objects["Sphere"])
            self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=3), {"FINISHED"})
            self.assertEqual(sorted(os.listdir(caches)), ["Sphere_top.bake3.pc2", "Sphere_top.pc2"])

    def test_a_detail_moved_since_binding_is_carried_from_where_it_is(self):
        # The bake carried details through the matrix taken at binding: a ball moved (or copied with
        # Shift+D) afterwards got the motion of the place it was bound at and floated off the shell.
        gshell = the_module()
        sphere, ball = shell_and_ball((1, 0, 0))
        addon_session.select([ball], sphere)
        self.assertEqual(bpy.ops.object.gshell_bind(), {"FINISHED"})
        ball.location = -ball.location  # to the other side of the sphere, still inside the layer
        bpy.context.view_layer.update()
        top = sphere.gshell.top
        shell = gshell.Shell(positions(sphere.data), np.asarray(top["gshell_faces"]).reshape(-1, 3),
                             positions(top.data), top.gshell.thickness)
        to_base = np.array(sphere.matrix_world.inverted())
        embedding = gshell.embed(shell, to_world(to_base, to_world(ball.matrix_world, positions(ball.data))))
        addon_session.animate_bend(sphere, 90, 1, 4)
        self.assertEqual(bpy.ops.object.gshell_bake(frame_start=1, frame_end=4), {"FINISHED"})
        deformer = gshell.Deformer(shell)
        for frame in range(1, 5):
            bpy.context.scene.frame_set(frame)
            deformer.solve(evaluated_positions(sphere))
        expected = to_world(sphere.matrix_world, embedding.carry(deformer.vertices))
        np.testing.assert_allclose(to_world(ball.matrix_world, evaluated_positions(ball)), expected, atol=1e-5)
        bound = np.array(ball.gshell.bind_matrix)  # bound again where it is
        np.testing.assert_allclose(bound, np.array(sphere.matrix_world.inverted() @ ball.matrix_world), atol=1e-6)

    def test_the_top_keeps_the_bases_active_uv_maps_and_materials(self):
        sphere = uv_sphere(segments=8, rings=4)
        mesh = sphere.data
        for name in ("Second", "Third"):
            mesh.uv_layers.new(name=name)
        mesh.uv_layers.active_index = 2
        mesh.uv_layers["Second"].active_render = True
        for name in ("Red", "Blue"):
            mesh.materials.append(bpy.data.materials.new(name))
        mesh.polygons[3].material_index = 1
        bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
        top = sphere.gshell.top.data
        self.assertEqual([layer.name for layer in top.uv_layers], [layer.name for layer in mesh.uv_layers])
        self.assertEqual(top.uv_layers.active.name, "Third")
        self.assertEqual([layer.name for layer in top.uv_layers if layer.active_render], ["Second"])
        self.assertEqual([m.name for m in top.materials], ["Red", "Blue"])
        self.assertEqual([p.material_index for p in top.polygons], [p.material_index for p in mesh.polygons])

    def test_a_linked_base_is_refused_and_its_library_override_keeps_its_shell(self):
        # Linked data is never saved, and the settings were not overridable: after saving and opening
        # again, the override of a linked character was a plain mesh with an orphaned top.
        self.addCleanup(bpy.ops.wm.read_homefile, use_empty=True)
        with tempfile.TemporaryDirectory() as folder:
            uv_sphere("LibBall", segments=12, rings=6)
            library = os.path.join(folder, "library.blend")
            bpy.ops.wm.save_as_mainfile(filepath=library)
            bpy.ops.wm.read_homefile(use_empty=True)
            shot = os.path.join(folder, "shot.blend")
            bpy.ops.wm.save_as_mainfile(filepath=shot)
            with bpy.data.libraries.load(library, link=True) as (source, linked):
                linked.objects = ["LibBall"]
            ball = linked.objects[0]
            bpy.context.collection.objects.link(ball)
            addon_session.select([ball], ball)
            with self.assertRaises(RuntimeError) as error:
                bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
            self.assertIn("'LibBall' is linked from", str(error.exception))
            self.assertEqual(ball.gshell.role, "NONE")
            bpy.ops.object.make_override_library()
            override = bpy.context.active_object
            self.assertIsNotNone(override.override_library)
            self.assertEqual(bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO), {"FINISHED"})
            top_name = override.gshell.top.name
            bpy.ops.wm.save_mainfile()
            bpy.ops.wm.open_mainfile(filepath=shot)
            override = next(o for o in bpy.data.objects if o.override_library)
            self.assertEqual((override.gshell.role, override.gshell.top.name), ("BASE", top_name))
            self.assertEqual(bpy.data.objects[top_name].gshell.base, override)

    def test_a_deformer_off_in_the_viewport_but_on_for_render_is_named(self):
        import gshell_blender
        sphere = uv_sphere(segments=8, rings=4)
        bpy.ops.object.gshell_generate(thickness_ratio=THICKNESS_RATIO)
        bend = addon_session.animate_bend(sphere, 60, 1, 2)
        subdivision = sphere.modifiers.new("Smooth it", "SUBSURF")  # off while baking, as the README says
        subdivision.show_viewport = False
        bake = gshell_blender.op_bake.Bake(the_module(), bpy.context, sphere, 1, 2, "")
        bake.cancel()
        self.assertNotIn("Bend", bake.warning or "")
        bend.show_viewport = False
        bake = gshell_blender.op_bake.Bake(the_module(), bpy.context, sphere, 1, 2, "")
        bake.cancel()
        self.assertIn("off in the viewport are left out of the bake, which follows the viewport: Bend", bake.warning)
        self.assertNotIn("Smooth it", bake.warning)

if __name__ == "__main__":
    addon_session.install_addon(addon_session.script_args()[0])
    suite = unittest.defaultTestLoader.loadTestsFromTestCase(AddonTest)
    result = unittest.TextTestRunner(stream=sys.stderr, verbosity=2).run(suite)
    if not result.wasSuccessful():
        raise SystemExit(1)
