"""The stretch bound's cost per step call: the mesh's edges against the links' estimate and off.

`scripts/bench stretch_bound`: the creature's mesh (opdeform.meshes.character(), 5,752 vertices, 17,250 edges) at
100 and 1,000 particles, half the particles softened (link softness 0.5 on the half of larger x), the goals
carrying the rest at the particles' centres, the bound at limit 50 (nothing raised: every variant steps the same
bits, so the difference is the bound's measuring). One call of 10 steps (the add-on's frame) from the same state,
restored before each; processor ms per call (median of 15). The bound runs once per call (docs/goals.md, "The
stretch bound on the mesh's edges (stop 50)")."""

import numpy as np

import opdeform
from opdeform import meshes

from .common import median_times, table


def creature_sim(vertices, triangles, particles):
    """A Simulation of the creature's mesh with half its links softened and goals on its rest; its Skin."""
    graph = opdeform.Graph.from_mesh(vertices, triangles, particles=particles)
    sim = opdeform.Simulation(graph, 1e5)
    sim.set_link_softness(np.where(graph.centers[:, 0] > np.median(graph.centers[:, 0]), 0.5, 1.0))
    sim.set_goal_frequencies(np.full(graph.n_particles, 5.0))
    sim.set_goals_carry_rest(True)
    sim.set_goals(graph.centers, np.tile(np.eye(3), (graph.n_particles, 1, 1)))
    sim.step(10)
    return sim, opdeform.Skin(graph, vertices)


def call_ms(sim):
    """Processor ms of one 10-step call from the sim's state as it is now."""
    state = (sim.positions, sim.rotations, sim.velocities, sim.angular_velocities)

    def call():
        sim._core.restore_state(*state)
        sim.step(10)
    return median_times(call, repeats=15)[1]


def run(argv):
    vertices, triangles = meshes.character()
    edges = np.unique(np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]),
                              axis=1), axis=0)
    rows = []
    for particles in (100, 1000):
        sim, skin = creature_sim(vertices, triangles, particles)
        sim.set_stretch_limit(0.0)
        off = call_ms(sim)
        sim.set_stretch_limit(50.0)
        links = call_ms(sim)
        sim.set_stretch_limit(50.0, skin=skin, edges=edges)
        mesh = call_ms(sim)
        rows.append((sim.graph.n_particles, f"{off:.3f}", f"{links:.3f}", f"{mesh:.3f}", f"{mesh - off:+.3f}"))
    print(f"the creature's mesh: {len(vertices)} vertices, {len(edges)} edges")
    table(rows, ("particles", "off ms", "links' estimate ms", "mesh edges ms", "mesh - off"))
