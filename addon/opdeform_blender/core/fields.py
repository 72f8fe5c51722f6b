"""Force fields acting on the particles, free of bpy: Blender's Wind, Force, Vortex and Turbulence fields as
plain records (``Field``), the acceleration each gives a point, and the seam where they reach the solvers.

Strength is an acceleration in m/s^2 at the field's origin (a 1 kg Soft Body point feels the same), already
multiplied by the effector weights (All times the field's kind). Falloff as Blender's: 1 / (1 + d - min)^power
with d the distance to the origin (Sphere), to the axis (Tube) or along it (Plane), 1 inside Min and 0 beyond
Max. Flow > 0 adds air drag: -flow * v. Noise adds a random push of noise * |strength| per particle and frame
(seeded by the field's seed and the frame, so replays repeat it).

The seam (until the core takes external forces, issue 13): ``opdeform.Simulation`` has gravity only, global.
``apply`` adds a frame's accelerations to the particles' velocities before the frame's step (v += a h, h the
frame's time) through ``Simulation.set_state``; ``wind_velocity`` gives the MPM world (tumbling particles),
whose air is a uniform velocity plus its own noise, the velocity the fields drive the air to at a point.
"""

from collections import namedtuple

import numpy as np

from .colliders import ColliderError

FIELD_KINDS = ("WIND", "FORCE", "VORTEX", "TURBULENCE")
Field = namedtuple("Field", "name kind strength origin axis falloff power min_distance max_distance noise flow "
                            "size seed")


def field(name, kind, strength, matrix, falloff="SPHERE", power=0.0, min_distance=0.0, max_distance=float("inf"),
          noise=0.0, flow=0.0, size=1.0, seed=0):
    """A Field from a force-field object's settings and 4x4 world matrix (its z axis is the field's axis);
    ColliderError naming the object on non-finite or degenerate input."""
    m = np.asarray(matrix, dtype=np.float64).reshape(4, 4)
    numbers = (strength, power, min_distance, noise, flow, size)
    if kind not in FIELD_KINDS:
        raise ColliderError(f"force field {name!r}: kind {kind!r} is not one of {', '.join(FIELD_KINDS)}")
    if not (np.all(np.isfinite(numbers)) and np.all(np.isfinite(m))):
        raise ColliderError(f"force field {name!r}: its strength, settings or transform are not finite (NaN)")
    axis = m[:3, 2]
    if not np.linalg.norm(axis) > 1e-12 or (kind == "TURBULENCE" and not size > 0.0):
        raise ColliderError(f"force field {name!r}: its axis (z) is degenerate or its size is not > 0")
    return Field(name, kind, float(strength), tuple(m[:3, 3]), tuple(axis / np.linalg.norm(axis)), falloff,
                 float(power), float(min_distance), float(max_distance), float(noise), float(flow), float(size),
                 int(seed))


def _distance(f, rel, axis):
    along = rel @ axis
    if f.falloff == "PLANE":
        return np.abs(along)
    if f.falloff == "TUBE":
        return np.linalg.norm(rel - along[:, None] * axis, axis=1)
    return np.linalg.norm(rel, axis=1)


def falloff(f, rel, axis):
    d = _distance(f, rel, axis)
    factor = np.power(1.0 + np.maximum(d - f.min_distance, 0.0), -f.power)
    return np.where(d > f.max_distance, 0.0, factor)


def _unit(v):
    n = np.linalg.norm(v, axis=1, keepdims=True)
    return np.divide(v, n, out=np.zeros_like(v), where=n > 1e-12)


def _turbulence(f, rel):
    """A smooth, bounded vector noise of the field's size: three random plane waves per component."""
    rng = np.random.default_rng(f.seed)
    waves, phases = rng.normal(size=(3, 3, 3)), rng.uniform(0.0, 2.0 * np.pi, (3, 3))
    return np.sin(np.einsum("cwd,nd->ncw", waves, rel / f.size) + phases).sum(axis=2) / 3.0


def direction(f, rel, axis):
    """The unit push of a field at points rel (relative to its origin), before strength and falloff."""
    if f.kind == "WIND":
        return np.broadcast_to(axis, rel.shape)
    if f.kind == "FORCE":
        return _unit(rel)
    if f.kind == "VORTEX":
        return _unit(np.cross(axis, rel))
    return _turbulence(f, rel)


def accelerations(fields, positions, velocities, frame):
    """(n, 3) accelerations of points at positions moving at velocities (world space) in a frame."""
    total = np.zeros_like(positions)
    for f in fields:
        rel, axis = positions - np.asarray(f.origin), np.asarray(f.axis)
        scale = f.strength * falloff(f, rel, axis)[:, None]
        total += scale * direction(f, rel, axis) - f.flow * velocities
        if f.noise > 0.0:
            rng = np.random.default_rng((f.seed, int(frame)))
            total += f.noise * abs(f.strength) * rng.normal(size=positions.shape)
    return total


def apply(sim, fields, dt, frame):
    """The seam: a frame's field accelerations reach the ARAP particles as a velocity change before its step."""
    if not fields:
        return
    pos, rot, vel, ang = sim.positions, sim.rotations, sim.velocities, sim.angular_velocities
    sim.set_state(pos, rot, vel + dt * accelerations(fields, pos, vel, frame), ang)


def wind_velocity(fields, point, drag):
    """The air velocity the fields drive toward at a point, for a world whose air relaxes to a uniform wind at
    rate drag (1/s): the acceleration at rest divided by drag (the same initial push as the ARAP particles)."""
    if not fields or not drag > 0.0:
        return np.zeros(3)
    p = np.asarray(point, dtype=np.float64).reshape(1, 3)
    steady = [f._replace(noise=0.0) for f in fields]
    return accelerations(steady, p, np.zeros_like(p), 0)[0] / drag


def mpm_wind(wind, fields, point, drag=8.0):
    """The tumbling world's wind settings (core/tumbling.py's ``settings_dict``; None: off) with the fields' air
    velocity at point (the domain's centre) added to its mean velocity; without a wind of its own, a uniform
    one relaxing at ``drag`` (the Tumbling Particles' default Air Drag)."""
    if not fields:
        return wind
    wind = dict(wind or {"kind": "noise", "amplitude": 0.0, "exponent": 0.0, "drag": drag})
    wind["velocity"] = tuple(np.add(wind.get("velocity", (0.0, 0.0, 0.0)), wind_velocity(fields, point,
                                                                                           wind["drag"])))
    return wind
