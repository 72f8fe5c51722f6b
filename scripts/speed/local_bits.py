"""md5 of positions, rotations and velocities of Fig. 1 (300 steps), Fig. 2 (180 frames), Fig. 4 (240 steps) and
the 10,000-particle beam (20 steps) on T threads (environment, default 1): equal lines mean the same bits
(docs/speed.md, "One core": the local step's batches against main before and OPDEFORM_NO_AVX2=1)."""
import hashlib
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from opdeform import scenes  # noqa: E402

from benchmarks.scale import beam  # noqa: E402


def digest(sim):
    data = b"".join(np.ascontiguousarray(a).tobytes() for a in (sim.positions, sim.rotations, sim.velocities))
    return hashlib.md5(data).hexdigest()[:10]


threads = int(os.environ.get("T", 1))
bar, twist, body, lattice = scenes.fig1_bar(), scenes.TwistedBar(), scenes.falling_body(), beam((100, 10, 10))
for sim in (bar, twist.sim, body, lattice):
    sim.set_solver(threads=threads)
bar.step(300)
for f in range(180):
    twist.animate(f / 60.0)
    twist.sim.step()
body.step(240)
lattice.step(20)
print(f"RESULT T={threads} " + " ".join(f"{name}={digest(sim)}" for name, sim in
                                         (("fig1", bar), ("fig2", twist.sim), ("fig4", body), ("beam10k", lattice))))
