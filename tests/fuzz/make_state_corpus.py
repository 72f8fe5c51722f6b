"""Seeds of the state-loading fuzz targets from real saved states (issue 28), written into
tests/fuzz/corpus/TARGET/seed-*: the bytes each target feeds to the loader it fuzzes.

    PYTHONPATH=build/python python3 tests/fuzz/make_state_corpus.py

- fuzz_mpm_state: ``mpm.World`` states (``World._core.save_state()``) of the world the target makes: the unit
  box, dx = 1/16, a floor at z = 0.1 and a sphere; snow, jelly and flakes, before and after steps and a
  collider move.
- fuzz_sim_state: the arrays a Simulation's pickle sets on the 8-particle chain the target makes (goal frames,
  goal motion, damping per particle, a constraint's target, the state), from a chain with goals at 1 Hz
  carrying the rest that follows moving goals for a few steps.
- fuzz_contact_state: ContactGroup states (an int32 pair count, the pairs, the forces) of the target's two
  chains 0.15 m apart, after 1 to 4 steps.
- fuzz_goal_fit: a GoalFit pickle's arguments on that chain (neighbours, rest vertices around the particles)
  and animated vertices (the rest turned and moved, scaled by 1e-3 to 1e3).
"""

import os

import numpy as np

import opdeform
from opdeform import mpm

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus")


def fuzz_world():
    world = mpm.World((0, 0, 0), (1, 1, 1), 1 / 16, threads=1)
    world.add_floor(0.1)
    world.add_collider("sphere", radius=0.1, translation=(0.5, 0.5, 0.8))
    return world


def mpm_states():
    rng = np.random.default_rng(28)
    for k, material in enumerate((mpm.snow(), mpm.jelly(), mpm.flakes())):
        world = fuzz_world()
        n = 4 + 2 * k
        world.add_particles(0.4 + 0.2 * rng.random((n, 3)), material=material, particle_volume=1e-4,
                            orientations=mpm.random_orientations(n, seed=k), velocities=rng.normal(size=(n, 3)))
        yield f"{material.kind}-0", world._core.save_state()
        world.step(1 / 60)
        yield f"{material.kind}-1", world._core.save_state()
        world.add_particles(0.5 + 0.1 * rng.random((3, 3)), material=mpm.snow(hardening=3.0), particle_volume=2e-4)
        world.move_collider(1, (0.5, 0.5, 0.6))
        world.step(1 / 30)
        yield f"{material.kind}-2", world._core.save_state()
    yield "empty", fuzz_world()._core.save_state()


def chain_simulation():
    n = 8
    centers = np.zeros((n, 3))
    centers[:, 0] = 0.2 * np.arange(n)
    edges = np.array([(e, e + 1) for e in range(n - 1)])
    graph = opdeform.Graph(centers, np.full((n, 3), 0.1), edges)
    sim = opdeform.Simulation(graph, 1e5)
    sim.set_goal_frequencies(np.ones(n))
    sim.set_goals_carry_rest(True)
    sim.add_position_constraint((0, 0, 0))
    sim.add_direction_constraint(centers[-1], (1, 0, 0))
    return sim, centers


def sim_states():
    sim, centers = chain_simulation()
    for frame in range(4):
        turn = np.array([[np.cos(0.1 * frame), -np.sin(0.1 * frame), 0], [np.sin(0.1 * frame), np.cos(0.1 * frame), 0],
                         [0, 0, 1]])
        sim.set_goals(centers @ turn.T + (0, 0, 0.01 * frame), np.tile(turn, (len(centers), 1, 1)))
        sim.set_particle_damping(np.linspace(0.0, 0.05 * frame, len(centers)))
        sim.step(2)
        velocities, spins, steps = sim.goal_motion
        goals = sim._goal_frames
        arrays = [goals[0], goals[1], velocities, spins, np.array([steps, 0], np.int32), sim.particle_damping,
                  np.array(sim._core.constraint_target(0)), sim.positions, sim.rotations, sim.velocities,
                  sim.angular_velocities]
        yield f"chain-{frame}", b"".join(np.ascontiguousarray(a).tobytes() for a in arrays)


def contact_states():
    a, centers = chain_simulation()
    b, _ = chain_simulation()
    b.set_state(centers + (0, 0, 0.15), np.tile(np.eye(3), (len(centers), 1, 1)))
    group = opdeform.ContactGroup([a, b])
    for steps in range(1, 5):
        group.step(1)
        pairs, forces = group.save_state()
        yield f"chains-{steps}", np.int32(len(pairs)).tobytes() + pairs.tobytes() + forces.tobytes()


def goal_fit_inputs():
    _, centers = chain_simulation()
    rest = np.concatenate([centers + offset for offset in ((0, 0.05, 0), (0, -0.05, 0), (0, 0, 0.05))])
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    for k, (neighbors, scale) in enumerate(((4, 1.0), (16, 1e3), (3, 1e-3), (64, 1.0))):
        animated = (rest @ turn.T + (0.1, 0.2, 0.3)) * scale
        head = np.array([neighbors, len(rest)], np.int32)
        yield f"chain-{k}", head.tobytes() + rest.tobytes() + animated.tobytes()


def write(target, seeds):
    folder = os.path.join(ROOT, target)
    os.makedirs(folder, exist_ok=True)
    for name, data in seeds:
        with open(os.path.join(folder, f"seed-{name}"), "wb") as f:
            f.write(data)


if __name__ == "__main__":
    write("fuzz_mpm_state", mpm_states())
    write("fuzz_sim_state", sim_states())
    write("fuzz_contact_state", contact_states())
    write("fuzz_goal_fit", goal_fit_inputs())
