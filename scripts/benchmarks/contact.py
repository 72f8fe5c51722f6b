"""What scene colliders cost (issue 13, docs/contact.md): ms/step of a drop with and without contact.

Each row times two simulations side by side in one run (features.side_by_side: alternating, medians of CPU time,
the wall time beside, one thread): the creature (a Suzanne-like blob) with 100 or 1,000 particles falling freely,
and the same body resting on a sphere or sliding down a 30-degree ramp (settled there before timing, so that every
particle near the collider is tested and pushed). Then the push-out of a skinned mesh against the skinning alone,
and the re-sampling of a deforming mesh collider per call; then contact between and within bodies
(docs/contact.md): a 10,000-particle beam (scale.beam) with and without self-contact, and two 1,000-particle
creatures in a ContactGroup, one resting on the other, against the two stepped alone. Option: --quick (3 repeats
of 20 calls)."""

import math
import os

import numpy as np

import opdeform
from opdeform import meshes

from .common import median_times, table
from .features import side_by_side
from .scale import beam

RAMP = (0.0, -math.sin(math.radians(30)), math.cos(math.radians(30)))


def creature(particles):
    v, t = meshes.creature(64)
    return v, t, opdeform.Graph.from_mesh(v, t, particles=particles)


def drop(graph, collider):
    """The body 0.1 m above the collider's top (or free: collider None), settled for 1 s when it has one."""
    sim = opdeform.Simulation(graph, 2e5, damping=0.02)
    lift = 1.1 - graph.centers[:, 2].min() + graph.radii.max()
    sim.set_state(graph.centers + (0.0, 0.0, lift), np.tile(np.eye(3), (graph.n_particles, 1, 1)))
    if collider == "sphere":
        sim.add_collider("sphere", radius=1.0)
    elif collider == "ramp":
        sim.add_collider("plane", normal=RAMP, translation=(0.0, 0.0, 1.0), friction=0.3)
    if collider:
        sim.step(60)
    return sim


def resample_ms(resolution, repeats):
    """(triangles, processor ms, wall ms) per update_collider_vertices of a 3,744-triangle sphere breathing, at a
    sampling resolution (medians)."""
    sv, st = meshes.capsule(radius=0.5, length=0.0, segments=48, rings=16)
    sim = opdeform.Simulation(opdeform.Graph([[0, 0, 5.0]], [[0.1] * 3], np.zeros((0, 2), int)), 1e5)
    cid = sim.add_collider("mesh", vertices=sv, triangles=st, resolution=resolution)
    k = [0]

    def breathe():
        sim.update_collider_vertices(cid, sv * (1.0 + 0.01 * (k[0] % 2)))
        k[0] += 1

    wall, cpu = median_times(breathe, repeats)
    return len(st), cpu, wall


def stacked_pair(graph, grouped):
    """Two creatures, the second dropped onto the first (on the floor), settled 0.5 s; a step of the group, or
    of the two alone (the second then falls through: only the timing is compared)."""
    lift = np.ptp(graph.centers[:, 2]) + 2.0 * graph.radii.max()
    sims = [opdeform.Simulation(graph, 2e5, damping=0.02) for _ in range(2)]
    for k, sim in enumerate(sims):
        sim.set_state(graph.centers + (0.0, 0.0, k * lift), np.tile(np.eye(3), (graph.n_particles, 1, 1)))
        sim.set_floor(graph.centers[:, 2].min() - graph.radii.max(), 0.5)
    if not grouped:
        return lambda: [sim.step() for sim in sims]
    group = opdeform.ContactGroup(sims)
    group.step(30)
    return group.step


def body_rows(repeats, inner):
    out = []
    free, touching = beam((100, 10, 10)), beam((100, 10, 10))
    touching.set_self_contact()
    times = side_by_side(free.step, touching.step, repeats=max(repeats // 3, 3), inner=max(inner // 20, 2))
    out.append((f"beam, {free.graph.n_particles:,} particles", "self-contact", *_cells(times)))
    graph = creature(1000)[2]
    times = side_by_side(stacked_pair(graph, False), stacked_pair(graph, True), repeats=repeats,
                         inner=max(inner // 10, 2))
    out.append((f"two creatures, {graph.n_particles:,} particles each", "ContactGroup, stacked", *_cells(times)))
    return out


def _cells(times):
    """A row's timing cells from side_by_side's (cpu without, cpu with, wall without, wall with)."""
    cpu0, cpu1, wall0, wall1 = times
    return f"{cpu0:.4f}", f"{cpu1:.4f}", f"{cpu1 / cpu0:.2f}", f"{wall0:.4f}", f"{wall1:.4f}"


def rows(repeats, inner):
    out = []
    for particles in (100, 1000):
        v, t, graph = creature(particles)
        free = drop(graph, None)
        for collider in ("sphere", "ramp"):
            touching = drop(graph, collider)
            times = side_by_side(free.step, touching.step, repeats=repeats, inner=inner)
            out.append((f"creature, {graph.n_particles} particles", f"on a {collider}", *_cells(times)))
        skin = opdeform.Skin(graph, *meshes.subdivide(v, t, levels=1)[:1], threads=1)
        times = side_by_side(lambda: skin.deform_sim(touching, push_out=False), lambda: skin.deform_sim(touching),
                             repeats=repeats, inner=max(inner // 10, 1))
        out.append((f"its skin, {skin.n_vertices:,} vertices", "deform_sim push_out, on the ramp", *_cells(times)))
    for resolution in (32, 64):
        triangles, cpu, wall = resample_ms(resolution, max(repeats // 3, 3))
        out.append((f"sphere mesh, {triangles:,} triangles", f"update_collider_vertices, resolution {resolution}",
                    "", f"{cpu:.1f}", "", "", f"{wall:.1f}"))
    return out


def run(args):
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    quick = "--quick" in args
    repeats, inner = (3, 20) if quick else (15, 100)
    table(rows(repeats, inner) + body_rows(repeats, inner), ["scene", "contact", "ms free fall", "ms with", "ratio",
                                                             "wall ms free fall", "wall ms with"])
    print("ms: processor time of one thread, the measure (other work on the machine slows both columns alike); "
          "wall ms: the same calls' wall time")
