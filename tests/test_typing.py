"""The typed API (issue 25): mypy reads opdeform's annotations (py.typed beside the package): a correct script
using the API passes, and each mistake planted in a copy of it (marked `# planted`) is reported on its line, and
nothing else is."""

import glob
import os
import re
import subprocess
import sys

import pytest

import opdeform

pytest.importorskip("mypy", reason="mypy is missing (scripts/setup)")

CORRECT = '''
import numpy as np
import opdeform

n = 10
centers = np.c_[(np.arange(n) + 0.5) * 0.1, np.zeros(n), np.zeros(n)]
graph = opdeform.Graph(centers, np.tile([0.05, 0.1, 0.1], (n, 1)), np.c_[np.arange(n - 1), np.arange(1, n)])
sim = opdeform.Simulation(graph, stiffness=1e9, dt=1 / 60)
pin: int = sim.add_position_constraint((0.0, 0.0, 0.0))
sim.set_constraint_weight(pin, 1e6)
sim.set_floor(height=-1.0, friction=0.5)
sim.set_solver(threads=2, tolerance=1e-3)
sim.step(10)
tip: np.ndarray = sim.positions[-1]
count: int = graph.n_particles
pieces, labels = graph.pieces()
skin = opdeform.Skin(graph, centers + 0.01)
moved: np.ndarray = skin.deform_sim(sim)
goals = opdeform.GoalFit(graph, centers)
fitted = goals.fit(centers)
out = opdeform.relative_deform(skin, centers + 0.01, sim, fitted)
strength: float = float(opdeform.goal_frequency(0.5))
group = opdeform.ContactGroup([sim])
group.step(2)
from opdeform import io, meshes, mpm
bar_vertices, bar_triangles = meshes.bar(segments=10)
io.write_obj("bar.obj", bar_vertices, bar_triangles)
read_vertices, read_triangles = io.read_obj("bar.obj")
world = mpm.World((0, 0, 0), (1, 1, 1), 0.05, spin=0.5)
world.add_particles(mpm.fill_box((0.2, 0.2, 0.2), (0.4, 0.4, 0.4), 0.02), mpm.snow(density=500.0))
world.step(1 / 24)
flakes_at: np.ndarray = world.positions
'''
PLANTED = [  # (line, what mypy must catch)
    ('sim.step("10")', "a string for an int"),
    ("sim.add_position_constraint((0.0, 0.0, 0.0), weight=\"heavy\")", "a string for a float"),
    ("name: str = graph.n_particles", "an int used as a string"),
    ("opdeform.Graph.from_mesh(centers, centers, particles=2.5)", "a float for an int"),
    ("sim.set_constraint_weight(pin)", "a missing argument"),
    ("text: str = sim.positions", "an array used as a string"),
    ("sim.set_solver(thread=2)", "a misspelt keyword"),
    ("opdeform.Skin(graph, centers, neighbors=None)", "None for an int"),
    ("opdeform.ContactGroup(sim)", "a Simulation for a sequence of them"),
    ("io.read_obj(42)", "an int for a file name"),
    ('mpm.World((0, 0, 0), (1, 1, 1), dx="fine")', "a string for a float"),
    ('world.add_particles(centers, material="snow")', "a string for a Material"),
    ("meshes.bar(segments=2.5)", "a float for an int"),
    ('frames: int = io.read_pc2("a.pc2")', "a tuple used as an int"),
    ("world.add_collider(shape=\"box\", threads=2)", "a keyword World.add_collider does not take"),
]


def mypy(tmp_path, source):
    """mypy's error lines (line number, message) on ``source``, opdeform found where this test imports it."""
    script = tmp_path / "script.py"
    script.write_text(source)
    env = dict(os.environ, MYPYPATH=os.path.dirname(os.path.dirname(opdeform.__file__)))
    done = subprocess.run([sys.executable, "-m", "mypy", "--follow-imports=silent", "--no-error-summary",
                           "--cache-dir", str(tmp_path / "cache"), str(script)], capture_output=True, text=True,
                          env=env, timeout=600)
    errors = [(int(m.group(1)), m.group(2)) for m in re.finditer(r"^.*?script\.py:(\d+): error: (.*)$", done.stdout,
                                                                  flags=re.M)]
    return done, errors


def test_a_correct_script_passes(tmp_path):
    done, errors = mypy(tmp_path, CORRECT)
    assert done.returncode == 0 and not errors, done.stdout + done.stderr


def test_the_whole_package_passes_mypy_strictly(tmp_path):
    """Every module and the _core stubs: annotated throughout (--disallow-untyped-defs: a function without
    annotations fails it) and consistent; bpy, distributed and matplotlib, which have no stubs, are Any."""
    folder = os.path.dirname(opdeform.__file__)
    done = subprocess.run([sys.executable, "-m", "mypy", "--ignore-missing-imports", "--disallow-untyped-defs",
                           "--disallow-incomplete-defs", "--cache-dir", str(tmp_path / "cache"), folder],
                          capture_output=True, text=True, timeout=600,
                          env=dict(os.environ, MYPYPATH=os.path.dirname(folder)))
    assert done.returncode == 0, done.stdout + done.stderr
    assert f"in {len(glob.glob(os.path.join(folder, '*.py*')))} source files" in done.stdout  # none left out


def test_every_planted_mistake_is_caught(tmp_path):
    first = CORRECT.count("\n") + 1
    source = CORRECT + "".join(f"{line}  # planted: {why}\n" for line, why in PLANTED)
    done, errors = mypy(tmp_path, source)
    caught = {line for line, _ in errors}
    missed = [PLANTED[k] for k in range(len(PLANTED)) if first + k not in caught]
    assert not missed, (missed, done.stdout)
    assert caught == set(range(first, first + len(PLANTED))), done.stdout  # nothing but the planted lines
