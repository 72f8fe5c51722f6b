"""The local step's AVX2 path (csrc/arap/local_avx2.c, chosen at run time on x86-64) against the scalar loop
(OPDEFORM_NO_AVX2=1): the sum of C_i with the same products added in the same order, and the sweep in batches of
up to four particles (local_step.c's schedule: the serial order's result, rearranged) whose polar decompositions
run in the lanes of a register with od_PolarRotationWarm's operations. So the paper's scenes, a static solve,
goals, the parallel sweep and a scrambled lattice whose Newton steps fail (the SVD in some lanes) give the same
states and the same count of fallbacks, bit for bit. Each scene runs in a fresh process per mode (the choice is
read once per process)."""

import numpy as np
import pytest

import fresh_process

# 1,000 particles in a 20 x 10 x 5 lattice, 4 edges each
LATTICE = """
idx = np.arange(1000).reshape(20, 10, 5)
centers = np.stack(np.meshgrid(*(np.arange(k) * 0.1 for k in (20, 10, 5)), indexing="ij"), -1).reshape(-1, 3)
edges = [np.stack([idx[:20 - a, :10 - b, :5 - c].ravel(), idx[a:, b:, c:].ravel()], 1)
         for a, b, c in ((1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0))]
g = opdeform.Graph(centers, np.full((1000, 3), 0.05), np.concatenate(edges))
sim = opdeform.Simulation(g, 1e9, damping=0.01)
"""
# uniformly random rotations (unit quaternions) and centres moved by 0.8 of their spacing
SCRAMBLE = """
rng = np.random.default_rng(5)
q = rng.normal(size=(1000, 4))
w, x, y, z = (q / np.linalg.norm(q, axis=1)[:, None]).T
rot = np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], 1).reshape(-1, 3, 3)
sim.set_state(centers + rng.normal(scale=0.08, size=(1000, 3)), rot)
"""
SCENES = {
    # Fig. 1: pinned bar, dynamics (the inertia's term)
    "fig1": """
sim = scenes.fig1_bar(damping=0.05)
sim.step(120)
""",
    # Fig. 2: position and direction constraints on the twisted end
    "fig2": """
tb = scenes.TwistedBar(damping=0.02)
for f in range(90):
    tb.animate(f / 60.0)
    tb.sim.step()
sim = tb.sim
""",
    # Fig. 4: 261 edges, floor and friction
    "fig4": """
sim = scenes.falling_body()
sim.step(120)
""",
    # no inertia's term: a static solve
    "static": """
sim = scenes.fig1_bar()
sim.solve_static(200)
""",
    # goals add their term after the inertia's
    "goals": """
sim = scenes.falling_body()
sim.set_goal_strength(0.5)
sim.set_goals(sim.graph.centers + [0.0, 0.0, -0.5])
sim.step(60)
""",
    # 1,000 particles on 2 threads: the blocks' interiors and the border on the pool; constrained particles alone
    "beam": LATTICE + """
for p in g.centers[g.centers[:, 0] == 0.0][::4]:
    sim.add_position_constraint(p)
sim.set_solver(threads=2)
sim.step(10)
""",
    # random rotations and jittered centres: about one Newton run in 50 falls back to the SVD, on 1 and 2 threads
    "scrambled": LATTICE + SCRAMBLE + """
sim.step(3)
""",
    "scrambled2": LATTICE + SCRAMBLE + """
sim.set_solver(threads=2)
sim.step(3)
""",
}
FALLBACKS = {"scrambled", "scrambled2"}


def run_scene(name, avx2):
    """The scene's positions, rotations, velocities and angular velocities, and its count of SVD fallbacks, from a
    fresh process."""
    code = ("import numpy as np\nimport opdeform\nfrom opdeform import scenes\n" + SCENES[name] +
            "write_out(sim.graph.n_particles, [sim.positions, sim.rotations, sim.velocities, sim.angular_velocities,"
            " [sim.counters['polar_fallbacks']]])\n")
    n, data = fresh_process.run(code, OPDEFORM_NO_AVX2="0" if avx2 else "1", OPENBLAS_NUM_THREADS="1")
    assert len(data) == n * (3 + 9 + 3 + 3) + 1
    return {"positions": data[:3 * n].reshape(n, 3), "rotations": data[3 * n:12 * n].reshape(n, 3, 3),
            "velocities": data[12 * n:15 * n].reshape(n, 3), "angular": data[15 * n:18 * n].reshape(n, 3)}, data[-1]


@pytest.mark.parametrize("name", sorted(SCENES))
def test_the_avx2_path_gives_the_scalar_states(name):
    (scalar, scalar_fallbacks), (wide, wide_fallbacks) = run_scene(name, avx2=False), run_scene(name, avx2=True)
    for field, values in scalar.items():
        assert np.isfinite(values).all()
        np.testing.assert_array_equal(wide[field], values, err_msg=field)
    # the scenes move and turn their particles: every term of the sum is exercised
    assert np.abs(scalar["rotations"] - np.eye(3)).max() > 1e-3
    assert wide_fallbacks == scalar_fallbacks
    assert (scalar_fallbacks > 100) == (name in FALLBACKS)
