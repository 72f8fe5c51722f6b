"""The soak scene (docs/hardening.md): a jiggling capsule body whose two end handles are moved every frame,
skinned every frame, for many steps. `run(steps)` measures what must not drift: the C core's allocation
count after warm-up (a warmed-up frame allocates nothing), the resident set size, the energy, the
orthonormality of the rotations, and - after the handles are released and the body settles without
gravity - how far the settled shape is from the rest shape up to a rigid motion (creep).

Used by tests/test_soak.py (short) and `scripts/bench soak` / `scripts/fuzz soak` (10,000 steps)."""

import math
import os
import time

import numpy as np

import opdeform
from opdeform import _core
from opdeform import mesh as opmesh
from opdeform import meshes
from test_core import rigid_residual  # RMS distance after the best rigid alignment (Kabsch)

WARMUP = 100


def rss_bytes():
    """Resident set size of this process (Linux /proc, Windows' working set), or 0 where unavailable."""
    if os.name == "nt":
        import ctypes
        counters = (ctypes.c_size_t * 9)(72)  # PROCESS_MEMORY_COUNTERS (72 bytes): [2] is WorkingSetSize
        known = ctypes.windll.kernel32.K32GetProcessMemoryInfo(ctypes.c_void_p(-1), counters, 72)
        return counters[2] if known else 0
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except OSError:
        return 0


def make_scene(particles=60):
    vertices, triangles = meshes.capsule(radius=0.1, length=0.6)
    graph = opmesh.graph_from_mesh(vertices, triangles, particles=particles)
    sim = opdeform.Simulation(graph, stiffness=2e4, density=1000.0, dt=1 / 60, iterations=5,
                              gravity=(0.0, 0.0, -9.81), damping=0.0)
    x = vertices[:, 0]
    ends = [np.flatnonzero(x < x.min() + 0.02), np.flatnonzero(x > x.max() - 0.02)]
    handles = [(opmesh.pin_vertices(sim, vertices, idx, weight=sim.default_weight() / len(idx)), vertices[idx])
               for idx in ends]
    skin = opmesh.Skin(graph, vertices, triangles=triangles)
    return sim, handles, skin, vertices


def handle_offset(frame, which):
    """Where handle `which` is moved at `frame`: two incommensurate wobbles, a few centimetres."""
    t = frame / 60.0
    phase = 1.7 * which
    return np.array([0.03 * math.sin(2.1 * t + phase), 0.05 * math.sin(3.3 * t + phase),
                     0.06 * math.sin(1.3 * t) * math.cos(0.7 * t + phase)])


def kinetic_energy(sim, masses):
    v = sim.velocities
    return 0.5 * float((masses * (v * v).sum(1)).sum())


def run(steps, settle=1500, samples=20, report=None):
    """Runs the soak for `steps` frames; returns a dict of measurements (see the module doc)."""
    sim, handles, skin, vertices = make_scene()
    graph = sim.graph
    masses = 1000.0 * graph.volumes
    out = np.empty((len(vertices), 3), np.float32)
    normals = np.empty_like(out)
    every = max(1, (steps - WARMUP) // samples)
    trace = {"step": [], "allocations": [], "rss": [], "kinetic": [], "objective": []}
    start, cpu_start = time.perf_counter(), time.process_time()
    for frame in range(steps):
        for which, (ids, rest_points) in enumerate(handles):
            offset = handle_offset(frame, which)
            for cid, p in zip(ids, rest_points):
                sim.set_constraint_target(cid, p + offset)
        sim.step()
        skin.deform(sim.positions, sim.rotations, out, normals)
        if frame + 1 >= WARMUP and (frame + 1 - WARMUP) % every == 0:
            trace["step"].append(frame + 1)
            trace["allocations"].append(_core.allocation_count())
            trace["rss"].append(rss_bytes())
            trace["kinetic"].append(kinetic_energy(sim, masses))
            trace["objective"].append(sim.energy())
            if report:
                report(frame + 1, trace)
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    finite = bool(np.isfinite(sim.positions).all() and np.isfinite(sim.rotations).all()
                  and np.isfinite(out).all() and np.isfinite(normals).all())
    rot = sim.rotations
    orthonormality = float(np.abs(np.einsum("nji,njk->nik", rot, rot) - np.eye(3)).max())

    # Release the handles, switch gravity off and let the body settle with some damping.
    for ids, _ in handles:
        for cid in ids:
            sim.remove_constraint(cid)
    sim.set_params(gravity=(0.0, 0.0, 0.0), damping=0.05)
    sim.step(settle)
    creep = rigid_residual(sim.positions, graph.centers)[0]
    size = float(np.ptp(graph.centers, axis=0).max())
    return {
        "steps": steps,
        "seconds": elapsed,
        "ms_per_step": 1e3 * elapsed / steps,
        "cpu_seconds": cpu,
        "cpu_ms_per_step": 1e3 * cpu / steps,
        "particles": graph.n_particles,
        "vertices": len(vertices),
        "finite": finite,
        "trace": trace,
        "allocations_after_warmup": trace["allocations"][-1] - trace["allocations"][0],
        "rss_growth": trace["rss"][-1] - trace["rss"][0],
        "kinetic_max_first_half": max(trace["kinetic"][: len(trace["kinetic"]) // 2]),
        "kinetic_max_second_half": max(trace["kinetic"][len(trace["kinetic"]) // 2:]),
        "objective_max": max(abs(e) for e in trace["objective"]),
        "orthonormality": orthonormality,
        "creep": creep,
        "creep_relative": creep / size,
        "residual_speed": float(np.abs(sim.velocities).max()),
    }


# What a soak must show (tests/test_soak.py and scripts/benchmarks/soak.py share these limits).
LIMITS = {
    "allocations_after_warmup": 0,  # C-core allocations from the first sample after warm-up to the last
    "rss_growth": 1 << 20,          # bytes of resident memory gained over the same span
    "kinetic_growth": 4.0,          # max kinetic energy of the second half / of the first half
    "orthonormality": 1e-9,         # max |RᵀR - I| of any particle
    "creep_relative": 1e-5,         # RMS distance of the settled shape from the rest shape (rigidly aligned) / size
    "residual_speed": 1e-3,         # m/s after settling: the body did settle
}


def failures(result, check_rss=True):
    """The limits a soak result breaks, as readable lines (empty when it passes)."""
    bad = []
    if not result["finite"]:
        bad.append("the state, skinned vertices or normals became non-finite")
    if result["allocations_after_warmup"] > LIMITS["allocations_after_warmup"]:
        bad.append(f"{result['allocations_after_warmup']} C-core allocations after warm-up (want none)")
    if check_rss and result["rss_growth"] > LIMITS["rss_growth"]:
        bad.append(f"resident memory grew by {result['rss_growth'] / 1024:.0f} KiB after warm-up")
    growth = result["kinetic_max_second_half"] / max(result["kinetic_max_first_half"], 1e-300)
    if not growth <= LIMITS["kinetic_growth"] or not math.isfinite(result["objective_max"]):
        bad.append(f"energy not bounded: kinetic maximum grew {growth:.3g}x, objective max {result['objective_max']}")
    if not result["orthonormality"] <= LIMITS["orthonormality"]:
        bad.append(f"rotations drifted from orthonormal by {result['orthonormality']:.3g}")
    if not result["creep_relative"] <= LIMITS["creep_relative"]:
        bad.append(f"rest shape crept: settled shape is {result['creep_relative']:.3g} of the size off the rest shape")
    if not result["residual_speed"] <= LIMITS["residual_speed"]:
        bad.append(f"the released body did not settle (speed {result['residual_speed']:.3g} m/s)")
    return bad
