"""Contact between bodies (issue 13, docs/contact.md "third round"): a bar dropped on another, bars started 10 cm
into each other and bars colliding head on, with contact inside the iterations (the default) and after them only
(in_iterations=False). Measures, not timings: where the upper bar is at 3 and 6 s (height above the lower one,
offset aside, the Kabsch turn of each bar's centres, its fastest particle, the skinned overlap as in
tests/test_body_contact.py), the fastest particle of the overlapping bars, the least centre distance head on."""

import numpy as np

import opdeform
from opdeform import meshes

from .common import table


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


def run(args):
    v, t, g = bars()
    rows = [stack_row(v, t, g, mu, inside) for inside in (True, False) for mu in (0.5, 2.0, 0.0)]
    rows += [overlap_row(g, inside) for inside in (True, False)]
    rows += [head_on_row(g, speed, inside) for speed in (1.5, 20.0) for inside in (True, False)]
    print("bar on a bar: height above (m) / aside (m) / turn of the lower, upper bar / upper's fastest particle "
          "(m/s)")
    table(rows, ["scene", "contact", "at 3 s", "at 6 s", "skinned overlap at 6 s (mm)"])
