"""A bent, spiky capsule made with the add-on and rendered by Blender (EEVEE, headless): the README's
picture of a baked shell carrying bound detail.

    blender/headless/run blender/examples/render_bend.py build/gshell_blender.zip docs/images/blender-bend.png

A quad UV sphere stretched into a capsule gets a shell (Generate Shell, ratio 0.05); 240 small cones
standing in the layer and a row of 15 balls lying in it are bound to it (Bind); a Simple Deform modifier
bends the capsule 150 degrees over frames 1-24; Bake carries the top and the detail. Frames 1, 12
and 24 are rendered side by side: the teal base, the orange detail, the top as a translucent skin.
"""
import math
import os
import sys
import tempfile

import numpy as np

import bpy
import bmesh
from mathutils import Matrix, Vector

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "headless"))
import addon_session  # noqa: E402

FRAMES = (1, 12, 24)
SIZE = (320, 420)
RADII = (0.7, 0.7, 1.8)  # the capsule's semi-axes
BEADS_AZIMUTH = math.radians(-25)  # towards the camera


def material(name, color, rim=False):
    """Principled surface; rim=True makes it clear where it faces the camera and milky at grazing
    angles, so a top surface shows the layer at the silhouette without hiding what is inside."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    bsdf = nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.45
    if rim:
        weight = nodes.new("ShaderNodeLayerWeight")
        weight.inputs["Blend"].default_value = 0.35
        power = nodes.new("ShaderNodeMath")
        power.operation = "POWER"
        power.inputs[1].default_value = 2.0
        links.new(weight.outputs["Facing"], power.inputs[0])
        links.new(power.outputs[0], bsdf.inputs["Alpha"])
        mat.blend_method = "BLEND"
        mat.shadow_method = "NONE"
        mat.show_transparent_back = False
    mat.diffuse_color = (*color, 1.0)
    return mat


def capsule():
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=32, radius=1.0)
    obj = bpy.context.active_object
    obj.name = "Capsule"
    obj.data.transform(Matrix.Diagonal((*RADII, 1.0)))
    bpy.ops.object.shade_smooth()
    return obj


def spikes(eta, count, rng):
    """`count` cones standing on the capsule, from just above the base to just below the top.

    Placed on the ideal ellipsoid, not on the mesh's faces: Blender's UV sphere does not number its
    faces the same way from run to run, and the picture should not change."""
    bm = bmesh.new()
    radii = Vector(RADII)
    for u in rng.normal(size=(count, 3)):
        u = Vector(u).normalized()
        point = u * radii
        normal = Vector((u.x / radii.x, u.y / radii.y, u.z / radii.z)).normalized()
        height = 0.8 * eta
        cone = bmesh.ops.create_cone(bm, cap_ends=True, segments=8, radius1=0.05, radius2=0.0, depth=height)
        frame = normal.to_track_quat("Z", "Y").to_matrix().to_4x4()
        frame.translation = point + normal * (0.08 * eta + 0.5 * height)
        bmesh.ops.transform(bm, matrix=frame, verts=cone["verts"])
    return addon_session.object_from_bmesh(bm, "Spikes")


def beads(eta, count):
    """A row of small balls in the middle of the layer, down the capsule's side facing the camera."""
    c, s = math.cos(BEADS_AZIMUTH), math.sin(BEADS_AZIMUTH)
    bm = bmesh.new()
    for i in range(count):
        theta = math.pi * (i + 1) / (count + 1)  # from the top pole to the bottom one
        z = RADII[2] * math.cos(theta)
        normal = Vector((c * math.sin(theta) / RADII[0], s * math.sin(theta) / RADII[1],
                         math.cos(theta) / RADII[2])).normalized()
        point = Vector((c * RADII[0] * math.sin(theta), s * RADII[1] * math.sin(theta), z)) + normal * (0.5 * eta)
        ball = bmesh.ops.create_icosphere(bm, subdivisions=2, radius=0.4 * eta)
        bmesh.ops.translate(bm, vec=point, verts=ball["verts"])
    obj = addon_session.object_from_bmesh(bm, "Beads")
    obj.data.polygons.foreach_set("use_smooth", [True] * len(obj.data.polygons))
    return obj


def render_side_by_side(scene, frames, path):
    """Renders `frames` and writes them as one PNG strip."""
    strips = []
    with tempfile.TemporaryDirectory() as folder:
        for f in frames:
            scene.frame_set(f)
            scene.render.filepath = os.path.join(folder, f"frame_{f}.png")
            bpy.ops.render.render(write_still=True)
            image = bpy.data.images.load(scene.render.filepath)
            w, h = image.size
            strips.append(np.array(image.pixels[:], dtype=np.float32).reshape(h, w, 4))
            bpy.data.images.remove(image)
    pixels = np.concatenate(strips, axis=1)
    h, w = pixels.shape[:2]
    out = bpy.data.images.new("strip", width=w, height=h, alpha=False)
    out.pixels = pixels.ravel()
    scene.render.image_settings.color_mode = "RGB"
    scene.render.image_settings.compression = 100
    out.save_render(path, scene=scene)


def stage(scene):
    """Orthographic camera looking at the bend plane (y-z) from +x, a sun, a light grey world."""
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    camera.data.type = "ORTHO"
    camera.data.ortho_scale = 4.3
    camera.rotation_euler = (math.radians(80), 0.0, math.radians(65))
    camera.location = Vector((0.0, 0.45, 0.0)) + camera.rotation_euler.to_matrix() @ Vector((0.0, 0.0, 8.0))
    scene.camera = camera
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    scene.collection.objects.link(sun)
    sun.data.energy = 2.5
    sun.rotation_euler = (math.radians(50), math.radians(20), math.radians(70))
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.35, 0.37, 0.4, 1.0)
    scene.world = world
    scene.render.engine = "BLENDER_EEVEE"
    scene.eevee.taa_render_samples = 16
    scene.render.resolution_x, scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.view_settings.view_transform = "Standard"


def main():
    args = addon_session.script_args()
    addon_session.install_addon(args[0])
    out = os.path.abspath(args[1])
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)

    base = capsule()
    bpy.ops.object.gshell_generate(thickness_ratio=0.05, method="rigid")
    top = base.gshell.top
    eta = top.gshell.thickness
    detail = [spikes(eta, 240, np.random.default_rng(7)), beads(eta, 15)]
    addon_session.select(detail + [base], base)
    bpy.ops.object.gshell_bind()
    addon_session.animate_bend(base, 150, FRAMES[0], FRAMES[-1])
    bpy.ops.object.gshell_bake(frame_start=FRAMES[0], frame_end=FRAMES[-1])

    base.data.materials.append(material("Base", (0.05, 0.35, 0.4)))
    detail[0].data.materials.append(material("Spikes", (0.9, 0.4, 0.08)))
    detail[1].data.materials.append(material("Beads", (0.95, 0.85, 0.2)))
    top.data.materials.append(material("Top", (0.8, 0.9, 1.0), rim=True))
    top.display_type = "TEXTURED"
    stage(bpy.context.scene)
    render_side_by_side(bpy.context.scene, FRAMES, out)
    print(f"wrote {out}")


main()
