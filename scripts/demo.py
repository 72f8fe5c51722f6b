"""scripts/demo: the paper's scenes (Figs. 1, 2 and 4), then every other part's demo that is present."""

import importlib
import os
import sys
import time

import numpy as np

from opdeform import scenes

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "out", "demo")


def timed_steps(step, count):
    t = time.perf_counter()
    for _ in range(count):
        step()
    return (time.perf_counter() - t) * 1e3 / count


def fig1():
    print("Fig. 1  bar fixed at one end face (25 position constraints), settling under gravity")
    sags = []
    for factor in (1, 2, 4):
        k = factor * scenes.BAR_STIFFNESS
        sim = scenes.fig1_bar(k, damping=0.05)
        ms = timed_steps(sim.step, 600)
        sags.append(scenes.tip_sag(sim))
        print(f"  k = {factor}x{scenes.BAR_STIFFNESS:.0e}: tip sag {sags[-1] * 1e3:7.2f} mm after 10 s, {ms:.4f} ms/step")
    print(f"  sag ratios k : 2k : 4k = 1 : {sags[0] / sags[1]:.2f} : {sags[0] / sags[2]:.2f} (paper: halves per doubling)")


def fig2():
    print("Fig. 2  bar twisted by 180 degrees and lifted at its free end (1 position + 3 direction constraints)")
    tb = scenes.TwistedBar(damping=0.02)
    frames = 180
    t = time.perf_counter()
    for f in range(frames):
        tb.animate(f / 60.0)
        tb.sim.step()
    ms = (time.perf_counter() - t) * 1e3 / frames
    end = tb.sim.skin_points([scenes.BAR_TIP])[0]
    print(f"  tip at ({end[0]:.3f}, {end[1]:.3f}, {end[2]:.3f}) m, target (1.700, 0.000, 0.500); {ms:.4f} ms/step")


def fig4():
    print("Fig. 4  100-particle, 261-edge body dropped on a floor with friction")
    sim = scenes.falling_body()
    g = sim.graph
    print(f"  graph: {g.n_particles} particles, {g.n_edges} edges")
    ms = timed_steps(sim.step, 240)
    low = scenes.lowest_point(sim)
    print(f"  after 4 s: lowest point {low * 1e3:+.3f} mm (floor at 0), mean height {sim.positions[:, 2].mean():.3f} m,"
          f" speed {np.linalg.norm(sim.velocities, axis=1).max():.4f} m/s; {ms:.4f} ms/step")


def extras():
    """Demos of the other parts (meshes and skinning, MPM snow, Blender renders) where present."""
    here = os.path.dirname(os.path.abspath(__file__))
    for name in ("demo_mesh", "demo_mpm", "demo_render"):
        if os.path.exists(os.path.join(here, name + ".py")):
            out = os.path.join(OUT, name.replace("demo_", ""))
            os.makedirs(out, exist_ok=True)
            print(f"== {name}")
            importlib.import_module(name).run(out)


def main():
    os.makedirs(OUT, exist_ok=True)
    fig1()
    fig2()
    fig4()
    if "--core" not in sys.argv:
        extras()


main()
