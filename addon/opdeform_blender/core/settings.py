"""The panel's settings in the artist's units (issue 14), free of bpy: the material presets, and the solver
parameters they mean for one body (``opdeform.materials``).

Two kinds of objects:
- **material units** (objects enabled with this version): Stiffness is a modulus in MPa at 1 m
  (``materials.stiffness_for`` turns it into the solver's k of each particle for the body's graph and size,
  so the same value looks the same at any size and particle count: with a goal by ``Units.scaling`` "goal"),
  Damping a rate per second, Quality an error tolerance per
  step (% of the body's size, Chebyshev-accelerated, at most Max Iterations pairs);
- **solver units** (the Advanced sub-panel's toggle; every object of a file saved before settings version 1):
  the raw k, a per-step damping share and a fixed iteration count, exactly as before. Setting ``stiffness``
  from a script turns it on, so scripts written for k keep their meaning.
"""

from dataclasses import dataclass

import numpy as np

SETTINGS_VERSION = 6  # stamped on an object when oriented particles are enabled; 0: a file made before
MATERIAL_UNITS_VERSION = 1  # the first version in material units (below it: solver units)
FOLLOW_VERSION = 3  # the first version whose goal weight is the follow value itself
SHELL_MIN_VERSION = 4  # the first version whose detached shells' Follow is mapped into [Shell Min, 1]
SIZE_FREE_VERSION = 5  # the first version whose goal look is the same at any size
JIGGLE_VERSION = 6  # the first version whose looks set Jiggle (Hz)
# Version 6: each look sets the Regions panel's Jiggle (Hz) (stop 47); an object saved before, its Jiggle never
# set, opened with Jiggle 0 and its look shown as Custom: it gets the jiggle of the look its other values hold.
# Version 5: with a goal (Goal on, Dynamic mode) the modulus and Sag's gravity scale with the body's size so that
# the same scene at any size moves the same in units of its size (opdeform.materials' "goal" rule); an older
# object keeps the "froude" rule of free bodies (Physical Scaling on), and with it its look.
# Version 4: a detached shell's Follow is mapped into [Shell Min, 1] (default 0.3); an older object keeps its
# painted values as they were (Shell Min 0) unless Shell Min was set.
# Version 3: the goal's group weight is the follow value itself (Goal Min..Max) where it multiplied the strength,
# and the goal holds the shape against gravity (Sag). An older object keeps its mapping (Max = its strength)
# and its full gravity (Sag 1).
# Version 2: stiffness_for calibrates k in bending, not under a uniform strain, and the presets' moduli were
# tripled to keep their droops; a version-1 modulus means about this times more now (exact for the presets).
V1_MODULUS_FACTOR = 3.0
# The add-on's default Shell Min: a detached shell's painted Follow mapped into [0.3, 1] (0.3: a 0.43 Hz goal), so
# that no shell is slower than that goal: a long one is held from its root only (opdeform's od_BeamShell), and
# ellie's 0.9 m trunk, painted to 0.05, swung back as a 0.7 Hz cantilever that no damping brought within 2 mm in
# 1 s (docs/goals.md, "Settling a detached shell"). Here, not in engine.py, which the looks below would import.
SHELL_FOLLOW_MIN = 0.3
CUSTOM = "Custom"
MPA = 1e6
PERCENT = 100.0


@dataclass(frozen=True)
class Units:
    """The dynamics settings as the panel holds them."""
    solver_units: bool
    modulus: float  # MPa at 1 m
    stiffness: float  # k, solver units
    density: float
    damping_rate: float  # per second
    damping: float  # per-step share, solver units
    tolerance: float  # % of the body's size
    max_iterations: int
    iterations: int  # per step, solver units
    substeps: int
    scaling: str = "froude"  # how the body's size scales the modulus and gravity: opdeform.materials.SCALINGS


# Looks for secondary motion on an animated character (the Goal sub-panel's menu), named by what the artist
# sees, as Maya's jiggle and the Wiggle add-ons name theirs: the body's material (MPa, density, damping per
# second), the painted regions' softness and damping, and the jiggle frequency that flesh painted Follow 0 rings
# at where no Softness group is picked (engine.jiggle_softness, on the body's links). Measured on
# tests/blender/character_scene.py's creature and scripts/outside_knight.py (docs/goals.md, "Looks", "Jiggle").
# Ticking Goal on an object whose material is still the default preset gives it DEFAULT_LOOK: a body as stiff as
# Rubber barely moves around its animation (tail 17 mm, ears 0.01 mm). Each look settles within 2 mm 1 s after
# the motion stops (the aim). Floppy took 12/s and Shell Min 0.4 to settle the dog's tail and ellie's
# trunk (docs/goals.md, "Floppy that settles"), which swung the knight's cape less than Fleshy; with each
# particle's Follow the least of its vertices' (stop 47) they settle at 9/s and Shell Min 0.25 (Fleshy's 3 MPa;
# at 1.5 MPa the creature's tail did not), so the looks are ordered in motion (Subtle < Fleshy < Floppy).
LOOKS = {
    "Subtle": dict(modulus=8.0, density=1050.0, damping_rate=9.0, soft_stiffness=0.3, region_damping=9.0,
                   jiggle_hz=3.5, shell_follow_min=SHELL_FOLLOW_MIN),
    "Fleshy": dict(modulus=3.0, density=1050.0, damping_rate=9.0, soft_stiffness=0.15, region_damping=9.0,
                   jiggle_hz=1.75, shell_follow_min=SHELL_FOLLOW_MIN),
    "Floppy": dict(modulus=3.0, density=1050.0, damping_rate=9.0, soft_stiffness=0.1, region_damping=9.0,
                   jiggle_hz=1.4, shell_follow_min=0.25),
}
DEFAULT_LOOK = "Fleshy"


def look_but_jiggle(values, rel=1e-4):
    """The name of the look whose values but Jiggle (Hz) these are (a dict of the looks' keys; within ``rel``),
    else CUSTOM."""
    for name, look in LOOKS.items():
        if all(abs(values[k] - v) <= rel * abs(v) for k, v in look.items() if k != "jiggle_hz"):
            return name
    return CUSTOM


def preset_values(materials, name):
    """The panel's values of a preset of ``materials.PRESETS``: modulus (MPa), density, damping_rate,
    tolerance (%)."""
    m = materials.PRESETS[name]
    return dict(modulus=m.modulus / MPA, density=m.density, damping_rate=m.damping,
                tolerance=m.tolerance * PERCENT)


def matching_preset(materials, values, rel=1e-4):
    """The name of the preset whose values these are (within ``rel``), else CUSTOM."""
    for name in materials.PRESETS:
        ref = preset_values(materials, name)
        if all(abs(values[k] - v) <= rel * abs(v) for k, v in ref.items()):
            return name
    return CUSTOM


def modulus_now(modulus, version):
    """The modulus (MPa) an object of settings ``version`` means today: a version-1 value times
    V1_MODULUS_FACTOR (its k came from a uniform strain), else as it is."""
    return modulus * V1_MODULUS_FACTOR if version == MATERIAL_UNITS_VERSION else modulus


def solver_settings(od, graph, u, fps, gravity):
    """(Simulation parameters, ``set_solver`` arguments) of the settings for this graph at ``fps``; in material
    units the modulus and ``gravity`` scaled with the body's size by ``u.scaling``."""
    dt = 1.0 / (fps * u.substeps)
    params = dict(density=u.density, dt=dt, iterations=u.iterations, gravity=tuple(gravity))
    if u.solver_units:
        return dict(params, stiffness=u.stiffness, damping=u.damping), dict(accelerator="none", tolerance=0.0)
    m = od.materials
    size = m.body_size(graph)
    params.update(stiffness=m.stiffness_for(graph, u.modulus * MPA, size, scaling=u.scaling),
                  gravity=m.acting_gravity(gravity, size, u.scaling), damping=m.step_damping(u.damping_rate, dt))
    return params, dict(accelerator=m.DEFAULT_ACCELERATOR, tolerance=u.tolerance / PERCENT,
                        max_iterations=u.max_iterations)


def region_damping(u, dt, weights, rate):
    """Per-vertex damping per step of a painted damping map: the body's damping at weight 0, ``rate`` (per
    second) at 1, blended as rates per second (the body's per-step share in solver units read as a rate)."""
    body = -np.log1p(-min(u.damping, 1.0 - 1e-12)) / dt if u.solver_units else u.damping_rate
    return -np.expm1(-(body + np.asarray(weights) * (rate - body)) * dt)
