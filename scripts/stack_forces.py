"""Issue 27, docs/contact.md "Stop 48": why the stacks bench's two rows that fail do (scripts/benchmarks/stacking.py's
slabs, the upper dropped 0.05 m onto the lower, as the bench places them).

    PYTHONPATH=build/python:scripts python3 scripts/stack_forces.py friction [RATE [FROM TO]]
    PYTHONPATH=build/python:scripts python3 scripts/stack_forces.py ring [RATE]
    PYTHONPATH=build/python:scripts python3 scripts/stack_forces.py flap [RATE [FROM STEPS]]

friction: a Jelly slab on one 1,000 times as dense (24 steps a second unless RATE), every step from FROM to TO s
(0.2 to 0.7): the upper's centre's move (mm), its pairs at their Coulomb bound, the load-weighted cosine between each
pair's friction and its relative slip over the step (-1: friction against the slip), the friction's sum across the
normal over the weight, the sum of the friction's magnitudes and of the bounds μ f_n over the weight.
ring: a Stiff slab 1e6 times as dense (1e8 kg/m³) on the lower one and alone on the floor dropped as far (240 steps a
second unless RATE), 2 to 4 s: the fastest particle's strongest frequencies and its speed over each second.
flap: the Jelly slab on one 1,000 times as dense (24 steps a second unless RATE), STEPS steps (8) from FROM s (3): the
light slab's fastest particle, its velocity and height (mm), and the normal force and normal's z of each of its pairs
with a force (docs/contact.md, "Stop 49").
"""

import sys

import numpy as np

import opdeform
from benchmarks.stacking import preset_body, slab

JELLY = 1050.0  # kg/m³, the preset's
MU = 0.5  # the bench's friction


def jelly_on_dense(rate):
    """The bench's Jelly slab dropped on one 1,000 times as dense: (lower, upper, their group)."""
    v, t = slab()
    lower = preset_body(v, t, 0.1, "Jelly", 1000 * JELLY, rate)
    upper = preset_body(v, t, 0.35, "Jelly", JELLY, rate)
    return lower, upper, opdeform.ContactGroup([lower, upper], friction=MU)


def friction(rate, start, end):
    lower, upper, group = jelly_on_dense(rate)
    weight = JELLY * 0.128 * 9.81  # the 0.8 x 0.8 x 0.2 m slab's
    group.step(int(start * rate))
    for k in range(int((end - start) * rate)):
        before = np.vstack([lower.positions, upper.positions])
        group.step(1)
        moved = np.vstack([lower.positions, upper.positions]) - before
        pairs, forces = (np.asarray(a) for a in group.save_state())
        pressing = forces[:, 0] > 0.0
        pairs, forces = pairs[pressing], forces[pressing]
        normal, tangent = forces[:, 4:7], forces[:, 1:4]
        slip = moved[pairs[:, 1]] - moved[pairs[:, 0]]
        slip -= (slip * normal).sum(axis=1)[:, None] * normal
        size = np.linalg.norm(tangent, axis=1)
        cosine = (tangent * slip).sum(axis=1) / np.maximum(size * np.linalg.norm(slip, axis=1), 1e-30)
        bound = MU * forces[:, 0]
        centre = 1e3 * moved[len(lower.positions):].mean(axis=0)
        print(f"{start + (k + 1) / rate:.3f} s: centre {centre[0]:+.2f} {centre[1]:+.2f} mm, at bound "
              f"{(size >= 0.999 * bound).sum()} of {len(forces)}, cos(friction, slip) "
              f"{np.sum(cosine * forces[:, 0]) / forces[:, 0].sum():+.2f}, friction/W {tangent[:, 0].sum() / weight:+.3f} "
              f"{tangent[:, 1].sum() / weight:+.3f}, sum |friction|/W {size.sum() / weight:.3f}, sum μ f_n/W "
              f"{bound.sum() / weight:.3f}", flush=True)


def flap(rate, start, steps):
    lower, upper, group = jelly_on_dense(rate)
    first = len(lower.positions)
    group.step(int(start * rate))
    for k in range(steps):
        group.step(1)
        i = np.abs(upper.velocities).max(axis=1).argmax()
        pairs, forces = (np.asarray(a) for a in group.save_state())
        mine = (pairs[:, 1] == first + i) & (forces[:, 0] > 0.0)
        listed = "; ".join(f"lower {p[0]}: {f[0]:.0f} N, n_z {f[6]:.2f}" for p, f in zip(pairs[mine], forces[mine]))
        print(f"{start + (k + 1) / rate:.3f} s: particle {i} at {np.round(upper.velocities[i], 3)} m/s, "
              f"{1e3 * upper.positions[i, 2]:.1f} mm; {listed or 'no pair with a force'}", flush=True)


def ring(rate):
    v, t = slab()
    lower = preset_body(v, t, 0.1, "Stiff", 100.0, rate)
    upper = preset_body(v, t, 0.35, "Stiff", 1e8, rate)
    alone = preset_body(v, t, 0.05, "Stiff", 1e8, rate)
    group = opdeform.ContactGroup([lower, upper], friction=MU)
    group.step(2 * rate)
    alone.step(2 * rate)
    stacked, single = [], []
    for _ in range(2 * rate):
        group.step(1)
        alone.step(1)
        stacked.append(upper.velocities.copy())
        single.append(alone.velocities.copy())
    for name, velocities in (("on the lower slab", np.array(stacked)), ("alone on the floor", np.array(single))):
        i = np.abs(velocities).max(axis=(0, 2)).argmax()
        axis = np.abs(velocities[:, i]).max(axis=0).argmax()
        series = velocities[:, i, axis] - velocities[:, i, axis].mean()
        spectrum, hertz = np.abs(np.fft.rfft(series)), np.fft.rfftfreq(len(series), 1 / rate)
        strongest = np.argsort(spectrum)[-3:][::-1]
        print(f"{name}: particle {i} along {'xyz'[axis]}, strongest at {', '.join(f'{h:g}' for h in hertz[strongest])} "
              f"Hz; fastest particle 2-3 s {np.abs(velocities[:rate]).max():.4f} m/s, 3-4 s "
              f"{np.abs(velocities[rate:]).max():.4f} m/s", flush=True)


def main(args):
    rate = int(args[1]) if len(args) > 1 else (240 if args[0] == "ring" else 24)
    if args[0] == "friction":
        friction(rate, *(map(float, args[2:4]) if len(args) > 3 else (0.2, 0.7)))
    elif args[0] == "flap":
        flap(rate, float(args[2]) if len(args) > 2 else 3.0, int(args[3]) if len(args) > 3 else 8)
    else:
        ring(rate)


if __name__ == "__main__":
    main(sys.argv[1:] or ["friction"])
