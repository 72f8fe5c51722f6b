"""Contact between bodies (issue 13, docs/contact.md "third round"): a bar dropped on another, bars started 10 cm
into each other and bars colliding head on, with contact inside the iterations (the default) and after them only
(in_iterations=False). Measures, not timings: where the upper bar is at 3 and 6 s (height above the lower one,
offset aside, the Kabsch turn of each bar's centres, its fastest particle, the skinned overlap as in
tests/test_body_contact.py), the fastest particle of the overlapping bars, the least centre distance head on.
Stacks (issue 27): slabs of each preset with density ratios 1/1000 to 1e6, spheres of each preset and two
creatures, one dropped on the other, 13 s: whether the upper one rests on top from 3 s on. `--stacks`: those
alone; `--rate N`: the stacks at N steps a second (60 unless given; the add-on's Match Frame Rate substeps give
240)."""

import time

import numpy as np

import opdeform
from opdeform import materials, meshes

from .common import table

SECONDS = 13


def bars():
    v, t = meshes.bar(length=0.6, width=0.3, segments=12, cross=4)
    v = v - v.mean(axis=0)
    return v, t, opdeform.Graph.from_mesh(v, t, particles=100)


def body(graph, offset, velocity=(0.0, 0.0, 0.0), gravity=(0.0, 0.0, 0.0)):
    sim = opdeform.Simulation(graph, 1e6, dt=1 / 60, gravity=gravity)
    n = graph.n_particles
    sim.set_state(graph.centers + offset, np.tile(np.eye(3), (n, 1, 1)), np.tile(velocity, (n, 1)))
    return sim


def turn(rest, now):
    """The angle (degrees) of the rotation that best carries the rest centres to the current ones (Kabsch)."""
    a, b = rest - rest.mean(axis=0), now - now.mean(axis=0)
    u, _, vt = np.linalg.svd(b.T @ a)
    r = u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt
    return np.degrees(np.arccos(np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0)))


def overlap(v, t, graph, lower, upper):
    shown = [opdeform.Skin(graph, v).deform_sim(sim, push_out=False) for sim in (lower, upper)]
    probe = opdeform.Simulation(graph, 1e6)
    probe.add_collider("mesh", vertices=shown[0], triangles=t, resolution=64)
    return max(-probe.collider_distances(shown[1]).min(), 0.0)


def stack_row(v, t, g, mu, inside):
    a, b = (body(g, (0.0, 0.0, z), gravity=(0.0, 0.0, -9.81)) for z in (0.0, 0.45))
    for sim in (a, b):
        sim.set_floor(-0.15, 0.5)
    group = opdeform.ContactGroup([a, b], friction=mu, in_iterations=inside)
    cells = []
    for _ in (3, 6):
        group.step(180)
        above = b.positions[:, 2].mean() - a.positions[:, 2].mean()
        aside = np.abs(b.positions[:, :2].mean(axis=0) - a.positions[:, :2].mean(axis=0)).max()
        cells.append(f"{above:.3f} / {aside:.3f} / {turn(g.centers, a.positions):.0f}°, "
                     f"{turn(g.centers, b.positions):.0f}° / {np.abs(b.velocities).max():.4f}")
    return (f"bar on a bar, μ = {mu}", "inside" if inside else "after", *cells,
            f"{overlap(v, t, g, a, b) * 1e3:.1f}")


def overlap_row(g, inside):
    a, b = body(g, (0.0, 0.0, 0.0)), body(g, (0.0, 0.0, 0.2))
    group = opdeform.ContactGroup([a, b], in_iterations=inside)
    fastest = 0.0
    for _ in range(30):
        group.step()
        fastest = max(fastest, np.abs(a.velocities).max(), np.abs(b.velocities).max())
    apart = b.positions[:, 2].mean() - a.positions[:, 2].mean()
    return "bars 10 cm into each other", "inside" if inside else "after", f"fastest {fastest:.2f} m/s", \
        f"{apart:.3f} m apart at 0.5 s", ""


def head_on_row(g, speed, inside):
    a, b = body(g, (0.0, 0.0, 0.0)), body(g, (0.0, 0.0, 0.4), (0.0, 0.0, -speed))
    group = opdeform.ContactGroup([a, b], friction=0.0, in_iterations=inside)
    least = np.inf
    for _ in range(30):
        group.step()
        least = min(least, b.positions[:, 2].mean() - a.positions[:, 2].mean())
    return f"head on at {speed:g} m/s", "inside" if inside else "after", f"least centre distance {least:.3f} m", \
        "", ""


def preset_body(v, t, z, preset, density=None, rate=60):
    """A body of a materials preset (its density unless given) at height z above its rest, on a floor at 0 (μ =
    0.5), stepping 1/rate s."""
    m = materials.PRESETS[preset]
    g = opdeform.Graph.from_mesh(v + (0.0, 0.0, z), t, particles=100)
    m = materials.Material(m.name, m.modulus, m.density if density is None else density, m.damping, m.tolerance)
    sim = materials.make_simulation(g, m, dt=1 / rate)
    sim.set_floor(0.0, 0.5)
    return sim


def rests(lower, upper, height, width, rate=60, seconds=SECONDS):
    """Steps a group of `lower` and `upper` (upper dropped on lower) for `seconds` and measures each second:
    whether the upper body is on top (its centre above the lower's by more than half the bodies' `height`, less
    than a quarter of their `width` aside, its fastest particle under 0.05 m/s) from 3 s on, and the figures of
    the worst second from 3 s on: (held, least height above, most aside, fastest particle, CPU seconds). The
    bodies step 1/rate s."""
    group = opdeform.ContactGroup([lower, upper], friction=0.5)
    least, most, fastest, clock = np.inf, 0.0, 0.0, time.process_time()
    for second in range(1, seconds + 1):
        group.step(rate)
        above = upper.positions[:, 2].mean() - lower.positions[:, 2].mean()
        aside = np.linalg.norm(upper.positions[:, :2].mean(axis=0) - lower.positions[:, :2].mean(axis=0))
        if second >= 3:
            least, most = min(least, above), max(most, aside)
            fastest = max(fastest, np.abs(upper.velocities).max())
    held = least > 0.5 * height and most < 0.25 * width and fastest < 0.05
    return held, least, most, fastest, time.process_time() - clock


def slab():
    """A 0.8 x 0.8 x 0.2 m slab centred at the origin."""
    v, t = meshes.bar(length=0.8, width=0.8, segments=8, cross=8)
    v = v - v.mean(axis=0)
    v[:, 2] *= 0.25
    return v, t


def slab_rows(presets, ratios, rate=60):
    """Two slabs of a preset, the upper dropped 0.05 m onto the lower, the upper `ratio` times as dense (a
    ratio below 1: the lower one the denser): held from 3 to 13 s?"""
    v, t = slab()
    rows = []
    for preset in presets:
        for ratio in ratios:
            light = materials.PRESETS[preset].density if ratio < 1e3 else 100.0  # densities up to 1e8
            lower_density, upper_density = (light, light * ratio) if ratio >= 1 else (light / ratio, light)
            lower = preset_body(v, t, 0.1, preset, lower_density, rate)
            upper = preset_body(v, t, 0.35, preset, upper_density, rate)
            held, least, most, fastest, cpu = rests(lower, upper, 0.2, 0.8, rate)
            rows.append((f"slabs, {preset}", f"{ratio:g}" if ratio >= 1 else f"1/{1 / ratio:g}",
                         "yes" if held else "**no**", f"{least:.3f}", f"{most:.3f}", f"{fastest:.3f}", f"{cpu:.1f}"))
    return rows


def round_rows(presets, rate=60):
    """A 0.6 m sphere dropped 0.1 m onto a like one, of each preset; two creatures (Rubber, 1.6 m long, 0.96 m
    tall, 0.54 m wide), one dropped 0.1 m onto the other."""
    v, t = meshes.capsule(radius=0.3, length=1e-3, segments=24, rings=8, body=1)
    rows = []
    cases = [(f"spheres, {p}", v + (0.0, 0.0, 0.3), t, 0.7, p, 0.6, 0.6) for p in presets]
    cv, ct = meshes.creature(24)
    cases.append(("creatures, Rubber", cv, ct, 1.06, "Rubber", 0.96, 0.54))
    for name, mv, mt, lift, preset, height, width in cases:
        lower, upper = preset_body(mv, mt, 0.0, preset, rate=rate), preset_body(mv, mt, lift, preset, rate=rate)
        held, least, most, fastest, cpu = rests(lower, upper, height, width, rate)
        rows.append((name, "1", "yes" if held else "**no**", f"{least:.3f}", f"{most:.3f}", f"{fastest:.3f}",
                     f"{cpu:.1f}"))
    return rows


def rate_of(args):
    """The steps a second `--rate N` asks for (60 without it)."""
    if "--rate" not in args:
        return 60
    at = args.index("--rate") + 1
    if at >= len(args) or not args[at].isdigit() or int(args[at]) < 1:
        raise SystemExit("stacking: --rate needs a whole number of steps a second, e.g. --rate 240")
    return int(args[at])


def run(args):
    rate = rate_of(args)
    print(f"stacks ({SECONDS} s at 1/{rate} s, 100 particles a body, μ = 0.5 between them and on the floor): held = "
          "at every second from 3 s on, the upper body's centre above the lower's by more than half their height, "
          "less than a quarter of their width aside, its fastest particle under 0.05 m/s; the figures are the "
          "worst of those seconds")
    columns = ["scene", "density ratio (upper / lower)", "held 3-13 s", "least height above (m)", "most aside (m)",
               "fastest particle (m/s)", "CPU s"]
    presets = ("Jelly", "Rubber", "Stiff")
    table(slab_rows(presets, (2, 10, 100, 1000, 1e6, 1 / 10, 1 / 1000), rate) + round_rows(presets, rate), columns)
    if "--stacks" in args:
        return
    v, t, g = bars()
    rows = [stack_row(v, t, g, mu, inside) for inside in (True, False) for mu in (0.5, 2.0, 0.0)]
    rows += [overlap_row(g, inside) for inside in (True, False)]
    rows += [head_on_row(g, speed, inside) for speed in (1.5, 20.0) for inside in (True, False)]
    print("bar on a bar: height above (m) / aside (m) / turn of the lower, upper bar / upper's fastest particle "
          "(m/s)")
    table(rows, ["scene", "contact", "at 3 s", "at 6 s", "skinned overlap at 6 s (mm)"])
