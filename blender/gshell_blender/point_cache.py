"""Baked vertex animation: PC2 point-cache files played back by a Mesh Cache modifier.

PC2 (3ds Max's point cache 2, read by Blender's Mesh Cache modifier): a 32-byte little-endian
header (b"POINTCACHE2\\0", version 1, point count, start frame, sample rate, sample count), then
per sample the points' float32 x, y, z. Files are written under a temporary name and put in place
together when all are complete (commit_all), so a cancelled or failed bake leaves the earlier caches
untouched.
"""
import contextlib
import os
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
    """writers[index]'s file could not be put in place; the message says what became of the others."""

    def __init__(self, index, message):
        super().__init__(message)
        self.index = index


def commit_all(writers):
    """Puts every writer's file in place, or none: the caches of one bake belong together (a top and
    its detail playing different bakes drift apart). The files they replace are moved aside first and
    put back if one cannot go in. Raises CommitError; the caller discards the writers then."""
    for index, writer in enumerate(writers):
        writer._file.close()
        if writer.written != writer.num_samples:
            raise CommitError(index, f"{writer.path}: {writer.written} of {writer.num_samples} samples written; "
                                     f"nothing was baked")
    moved = []  # (path, where its earlier file is, or None)
    for index, writer in enumerate(writers):
        try:
            aside = writer.path + ".old" if os.path.exists(writer.path) else None
            if aside:
                os.replace(writer.path, aside)
            moved.append((writer.path, aside))
            os.replace(writer._tmp, writer.path)
        except OSError as e:
            stuck = _put_back(moved)
            raise CommitError(index, f"cannot put {writer.path} in place ({e.strerror or e}); " + (
                f"the earlier caches {', '.join(stuck)} could not be put back: bake again" if stuck else
                "nothing was baked, the earlier caches are as they were")) from e
    for _, aside in moved:
        if aside:
            with contextlib.suppress(OSError):  # the bake is in place; a leftover .old harms nothing
                os.remove(aside)


def _put_back(moved):
    """Undoes commit_all's moves; returns the paths it could not restore."""
    stuck = []
    for path, aside in reversed(moved):
        try:
            if aside:
                os.replace(aside, path)
            elif os.path.exists(path):
                os.remove(path)
        except OSError:
            stuck.append(path)
    return stuck


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


def detach(obj):
    mod = obj.modifiers.get(MODIFIER_NAME)
    if mod is not None:
        obj.modifiers.remove(mod)
