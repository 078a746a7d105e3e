"""Baked vertex animation: PC2 point-cache files played back by a Mesh Cache modifier.

PC2 (3ds Max's point cache 2, read by Blender's Mesh Cache modifier): a 32-byte little-endian
header (b"POINTCACHE2\\0", version 1, point count, start frame, sample rate, sample count), then
per sample the points' float32 x, y, z. Files are written under a temporary name and put in place
together when all are complete (commit_all), each under a name of its own, so a cancelled or failed
bake leaves the earlier caches untouched and an undone re-bake plays its own files again.
"""
import contextlib
import os
import re
import struct

import numpy as np

import bpy

MODIFIER_NAME = "gshell bake"
_HEADER = struct.Struct("<12siiffi")


class PointCacheWriter:
    """Writes one PC2 file sample by sample; commit_all() puts it in place, discard() drops it."""

    def __init__(self, path, num_points, start_frame, num_samples):
        self.path = path
        self.num_points = num_points
        self.num_samples = num_samples
        self.written = 0
        os.makedirs(os.path.dirname(path), exist_ok=True)
        self._tmp = path + ".part"
        self._file = open(self._tmp, "wb")
        self._file.write(_HEADER.pack(b"POINTCACHE2\0", 1, num_points, float(start_frame), 1.0, num_samples))

    def write(self, P):
        P = np.ascontiguousarray(P, dtype="<f4")
        assert P.shape == (self.num_points, 3), (P.shape, self.num_points)
        self._file.write(P.tobytes())
        self.written += 1

    def discard(self):
        self._file.close()
        if os.path.exists(self._tmp):
            os.remove(self._tmp)


class CommitError(Exception):
    """writers[index]'s file could not be put in place; nothing of the bake was."""

    def __init__(self, index, message):
        super().__init__(message)
        self.index = index


# A bake never writes over an earlier bake's file: each writes the next version of every object's
# cache, "<name>.pc2", then "<name>.bake2.pc2", "<name>.bake3.pc2", ... (clean names have no dots;
# the ".001" of a name clash comes before the version). An undo after a re-bake brings back the
# modifier that plays the earlier file, which is then still there: overwritten, it would have played
# the new bake's samples at the old bake's frames. A bake removes the versions nothing plays.
_VERSION = re.compile(r"^(?P<name>[^.]+(?:\.\d{3})?)(?:\.bake(?P<version>\d+))?\.pc2$")


def _versions(folder, name):
    """{version: file name} of `name`'s caches in `folder` (version 1: "<name>.pc2")."""
    found = {}
    with contextlib.suppress(OSError):
        for entry in os.listdir(folder):
            match = _VERSION.match(entry)
            if match and match["name"] == name:
                found[int(match["version"] or 1)] = entry
    return found


def next_version_path(folder, name):
    """The path of `name`'s next cache version in `folder` (no file of that name exists)."""
    version = max(_versions(folder, name), default=0) + 1
    return os.path.join(folder, f"{name}.pc2" if version == 1 else f"{name}.bake{version}.pc2")


def commit_all(writers, names, playing):
    """Puts every writer's file in place (at its new path), or none: the caches of one bake belong
    together (a top and its detail playing different bakes drift apart). Then removes the earlier
    versions of each name (`names[i]`: writers[i]'s) but those in `playing` (absolute paths that
    modifiers play: the bake's objects before it, so that one undo finds its files, and copies of
    them). Raises CommitError; the caller discards the writers then."""
    for index, writer in enumerate(writers):
        writer._file.close()
        if writer.written != writer.num_samples:
            raise CommitError(index, f"{writer.path}: {writer.written} of {writer.num_samples} samples written; "
                                     f"nothing was baked")
    placed = []
    for index, writer in enumerate(writers):
        try:
            os.replace(writer._tmp, writer.path)
            placed.append(writer.path)
        except OSError as e:
            for path in placed:
                with contextlib.suppress(OSError):
                    os.replace(path, path + ".part")  # back to a temporary, which discard() removes
            raise CommitError(index, f"cannot put {writer.path} in place ({e.strerror or e}); nothing was baked, "
                                     f"the earlier caches are as they were") from e
    kept = {os.path.normcase(os.path.realpath(p)) for p in playing}
    for writer, name in zip(writers, names):
        folder = os.path.dirname(writer.path)
        for entry in _versions(folder, name).values():
            path = os.path.join(folder, entry)
            if path != writer.path and os.path.normcase(os.path.realpath(path)) not in kept:
                with contextlib.suppress(OSError):  # the bake is in place; an old version left harms nothing
                    os.remove(path)


def read(path):
    """(start frame, float32 array (samples, points, 3)) of a PC2 file."""
    with open(path, "rb") as f:
        magic, version, points, start, rate, samples = _HEADER.unpack(f.read(_HEADER.size))
        if magic != b"POINTCACHE2\0" or version != 1:
            raise ValueError(f"{path}: not a PC2 file")
        data = np.frombuffer(f.read(), dtype="<f4")
    return start, data.reshape(samples, points, 3)


def attach(obj, path, frame_start):
    """Plays `path` on `obj`: a Mesh Cache modifier named MODIFIER_NAME, first in the stack (the
    cache replaces the mesh's own positions; the object's other modifiers apply on top of it)."""
    mod = obj.modifiers.get(MODIFIER_NAME)
    if mod is None or mod.type != "MESH_CACHE":
        if mod is not None:
            obj.modifiers.remove(mod)
        mod = obj.modifiers.new(MODIFIER_NAME, "MESH_CACHE")
    mod.cache_format = "PC2"
    mod.filepath = bpy.path.relpath(path) if bpy.data.filepath else path
    mod.deform_mode = "OVERWRITE"
    mod.play_mode = "SCENE"
    mod.time_mode = "FRAME"
    mod.interpolation = "LINEAR"
    mod.frame_start = frame_start  # sample 0 plays at frame_start
    mod.frame_scale = 1.0
    mod.forward_axis = "POS_Y"  # Blender's own axes: no conversion
    mod.up_axis = "POS_Z"
    mod.flip_axis = set()
    index = list(obj.modifiers).index(mod)
    if index != 0:
        with bpy.context.temp_override(object=obj):
            bpy.ops.object.modifier_move_to_index(modifier=mod.name, index=0)
    return mod


def playing_paths():
    """Absolute paths of the PC2 files Mesh Cache modifiers in the file play."""
    return [bpy.path.abspath(m.filepath) for o in bpy.data.objects for m in o.modifiers
            if m.type == "MESH_CACHE" and m.filepath]


def detach(obj):
    mod = obj.modifiers.get(MODIFIER_NAME)
    if mod is not None:
        obj.modifiers.remove(mod)
