"""Force fields acting on the particles, free of bpy: Blender's Wind, Force, Vortex and Turbulence fields as
plain records (``Field``), checked before anything changes, and kept in step with the force fields of a solver
(``add_force_field`` and friends on an ``opdeform.Simulation`` or an ``opdeform.mpm.World``, docs/forces.md).

Strength is an acceleration in m/s^2 at the field's origin (a 1 kg Soft Body point feels the same), already
multiplied by the effector weights (All times the field's kind). The core's falloff is Blender's: 1 within Min,
(1 + r - min)^-power beyond, 0 past Max; r along the axis for Wind, from the origin for the others (the core's
shapes: Blender's Falloff Shape is not read). Flow is the core's drag (1/s: a body in a wind tends to
strength / flow), Noise a wind's turbulence (of feature Size, seeded by Seed).
"""

from collections import namedtuple

import numpy as np

from .colliders import ColliderError, Kept

FIELD_KINDS = ("WIND", "FORCE", "VORTEX", "TURBULENCE")
Field = namedtuple("Field", "name kind strength origin axis power min_distance max_distance noise flow size seed")


def field(name, kind, strength, matrix, power=0.0, min_distance=0.0, max_distance=0.0, noise=0.0, flow=0.0,
          size=1.0, seed=0):
    """A Field from a force-field object's settings and 4x4 world matrix (its z axis is the field's axis;
    max_distance 0: unlimited); ColliderError naming the object on non-finite or degenerate input."""
    m = np.asarray(matrix, dtype=np.float64).reshape(4, 4)
    numbers = (strength, power, min_distance, max_distance, noise, flow, size)
    if kind not in FIELD_KINDS:
        raise ColliderError(f"force field {name!r}: kind {kind!r} is not one of {', '.join(FIELD_KINDS)}")
    if not (np.all(np.isfinite(numbers)) and np.all(np.isfinite(m))):
        raise ColliderError(f"force field {name!r}: its strength, settings or transform are not finite (NaN)")
    axis = m[:3, 2]
    if not np.linalg.norm(axis) > 1e-12:
        raise ColliderError(f"force field {name!r}: its axis (z) is degenerate")
    size = size if size > 0.0 else 1.0  # Blender's 0 (its default): unscaled noise, features of 1 m
    return Field(name, kind, float(strength), tuple(m[:3, 3]), tuple(axis / np.linalg.norm(axis)), float(power),
                 float(min_distance), float(max_distance), float(noise), float(flow), float(size), int(seed))


def core_arguments(f):
    """``add_force_field``'s arguments for a Field."""
    return dict(kind=f.kind.lower(), strength=f.strength, position=f.origin, direction=f.axis,
                turbulence=f.noise if f.kind == "WIND" else 0.0, size=f.size, falloff=f.power,
                min_distance=f.min_distance, max_distance=f.max_distance, drag=f.flow, seed=f.seed)


def _placed_alike(a, b):
    """Whether two frames of fields differ at most in where they are (origin, axis): a move suffices."""
    return len(a) == len(b) and all(p._replace(origin=q.origin, axis=q.axis) == q for p, q in zip(a, b))


class SceneFields(Kept):
    """A solver's force fields as the scene's: before each step ``set`` moves them to the frame's (the same set
    with other origins or axes) or places them anew (remove all, add all in order). Both give the same bits
    (the core normalises an axis the same way either way), so the fields of a step are a function of its frame
    alone and a bake equals playback."""

    what = "force field"

    def __init__(self, solver):
        self.solver = solver
        self.ids = []
        self.current = ()

    def set(self, fields):
        fields = tuple(fields)
        if fields == self.current:
            return
        if self.current is None or not _placed_alike(self.current, fields):
            self._place(fields)
        else:
            for fid, f in zip(self.ids, fields):
                self._call(f, self.solver.move_force_field, fid, f.origin, f.axis)
        self.current = fields

    def _place(self, fields):
        for fid in self.ids:
            self.solver.remove_force_field(fid)
        self.ids, self.current = [], ()
        for f in fields:
            self.ids.append(self._call(f, self.solver.add_force_field, **core_arguments(f)))
