"""Fork safety and thread counts (issue 15, items 1 and 2; docs/hardening.md).

Every threaded object (a Simulation on 2 threads, a Skin above 16,384 vertices, an MPM world, CHOLMOD's
supernodal factorization and its OpenMP team) is used in the parent, then used and deleted in a child made
by os.fork and by multiprocessing's fork context: the child must finish (before: it hung forever waiting on
the parent's threads). Thread counts: threads=0 follows the affinity mask and OMP_NUM_THREADS; counts above
the limit are refused naming `threads`."""

import multiprocessing
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import opdeform
from opdeform import mpm

TIMEOUT = 30
NO_FORK = pytest.mark.skipif(not hasattr(os, "fork"), reason="Windows has no fork (os.fork, multiprocessing's fork)")
# the worker-thread counts read /proc/self/task and pin with os.sched_setaffinity: Linux only
CPUS = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 0
TWO_CPUS = pytest.mark.skipif(CPUS < 2, reason="needs Linux's /proc and affinity calls (not Windows'), and two CPUs to tell "
                              "one from all")


def _lattice(nx, ny, nz, s=0.1):
    idx = np.arange(nx * ny * nz).reshape(nx, ny, nz)
    centers = np.stack(np.meshgrid(*(np.arange(k) * s for k in (nx, ny, nz)), indexing="ij"), -1).reshape(-1, 3)
    edges = []
    for d in [(1, 0, 0), (0, 1, 0), (0, 0, 1)]:
        edges += list(zip(idx[: nx - d[0], : ny - d[1], : nz - d[2]].ravel(), idx[d[0]:, d[1]:, d[2]:].ravel()))
    return opdeform.Graph(centers, np.full((len(centers), 3), 0.4 * s), np.array(edges))


def _threaded_sim():
    sim = opdeform.Simulation(_lattice(24, 6, 6), 1e6)  # 864 particles: the sweep splits (>= 512)
    sim.set_solver(threads=2)
    sim.add_position_constraint((0, 0, 0))
    return sim, lambda: sim.step(1)


def _supernodal_sim():
    sim = opdeform.Simulation(_lattice(20, 12, 12), 1e6)
    sim.set_solver(factorization="supernodal")  # CHOLMOD starts its OpenMP team here
    sim.add_position_constraint((0, 0, 0))

    def use():
        sim.set_params(stiffness=sim.params["stiffness"] * 1.01)  # refactors
        sim.step(1)
    return sim, use


def _big_skin():
    graph = _lattice(5, 5, 5)
    skin = opdeform.Skin(graph, np.random.default_rng(0).random((20000, 3)) * 0.4, threads=2)
    rotations = np.tile(np.eye(3), (graph.n_particles, 1, 1))
    return skin, lambda: skin.deform(graph.centers, rotations)


def _world():
    world = mpm.World((0, 0, 0), (1, 1, 1), 1 / 32, threads=2)
    world.add_particles(mpm.fill_box((0.3, 0.3, 0.3), (0.6, 0.6, 0.6), 1 / 64))
    return world, lambda: world.step(1 / 240)


MAKERS = {"simulation threads=2": _threaded_sim, "supernodal CHOLMOD": _supernodal_sim, "skin 20000": _big_skin,
          "mpm world": _world}
_USE = {}


def _use_in_child(name):
    _USE.pop(name)()  # use, then delete the object (the last reference is the closure)
    return name


@NO_FORK
@pytest.mark.parametrize("name", sorted(MAKERS))
def test_os_fork_child_uses_and_deletes_a_threaded_object(name):
    obj, use = MAKERS[name]()
    use()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child
        signal.alarm(TIMEOUT)
        try:
            use()
            del obj, use
            os._exit(0)
        except BaseException:
            os._exit(3)
    start = time.monotonic()
    while time.monotonic() - start < TIMEOUT:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            assert os.waitstatus_to_exitcode(status) == 0
            break
        time.sleep(0.02)
    else:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        pytest.fail(f"{name}: the forked child hung")
    use()  # the parent's object still works on its threads


@NO_FORK
def test_multiprocessing_fork_pool_maps_over_threaded_objects():
    for name, make in MAKERS.items():
        obj, use = make()
        use()
        _USE[name] = use
    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(2) as pool:
        done = pool.map_async(_use_in_child, sorted(MAKERS)).get(timeout=TIMEOUT)
    assert done == sorted(MAKERS)
    _USE.clear()


def _worker_threads(code, env=None):
    """The OS threads a fresh interpreter gains by running `code` (after importing opdeform and numpy)."""
    script = textwrap.dedent("""
        import os, numpy as np, opdeform
        from opdeform import mpm
        def tasks():
            return len(os.listdir("/proc/self/task"))
        before = tasks()
        """) + textwrap.dedent(code) + "\nprint(tasks() - before)\n"
    inherited = {k: v for k, v in os.environ.items() if k != "OMP_NUM_THREADS"}  # other tests may set it
    out = subprocess.run([sys.executable, "-c", script], env={**inherited, **(env or {})}, capture_output=True,
                         text=True, timeout=TIMEOUT)
    assert out.returncode == 0, out.stderr
    return int(out.stdout.split()[-1])


WORLD = "w = mpm.World((0, 0, 0), (1, 1, 1), 1 / 16, threads=0)\n"


@TWO_CPUS
def test_threads_zero_follows_the_affinity_mask():
    assert _worker_threads(WORLD) == min(CPUS, 64) - 1
    pinned = "os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})\n" + WORLD
    assert _worker_threads(pinned) == 0  # before: one worker per online core


@TWO_CPUS
def test_threads_zero_is_at_most_omp_num_threads():
    assert _worker_threads(WORLD, {"OMP_NUM_THREADS": "1"}) == 0
    assert _worker_threads(WORLD, {"OMP_NUM_THREADS": "1,1"}) == 0  # a nested list: its first entry
    assert _worker_threads(WORLD, {"OMP_NUM_THREADS": "junk"}) == min(CPUS, 64) - 1


def test_thread_counts_above_the_limit_are_refused_naming_threads():
    graph = _lattice(2, 2, 2)
    sim = opdeform.Simulation(graph, 1e6)
    for bad in (65, 256, -1):
        with pytest.raises(ValueError, match=r"threads = -?\d+ must be in \[0, 64\]"):
            sim.set_solver(threads=bad)
        with pytest.raises(ValueError, match=r"threads = -?\d+ must be in \[0, 64\]"):
            opdeform.Skin(graph, np.zeros((40000, 3)), threads=bad)  # before: 255 OS threads for 256
        with pytest.raises(ValueError, match=r"threads = -?\d+ must be in \[0, 64\]"):
            mpm.World((0, 0, 0), (1, 1, 1), 1 / 16, threads=bad)
    sim.set_solver(threads=64)
    sim.step(1)
