"""The figures of docs/contact.md's "Contact inside the iterations" (issue 27): the 0.3 m cube on a 30-degree
plane at 1/24, 1/60 and 1/240 s (mu = 1 and 0.3), the k = 1e15 capsule at rest on the floor and on a plane
(mu = 0.5, 3 s, 1/24 to 1/240 s), the blob's rebound from a 1 m drop, and the add-on test's soft blob dropped on
a sphere at 24 fps (its skin's mean height over 10 s), and the pairs a step takes under the presets' tolerance (the cube, Rubber);
slide: the colliders bench's Suzanne dropped on a 30-degree mesh ramp (tests/test_contact.py) at 24, 60 and 240 Hz,
mu = 0.3 and 0.5, against Coulomb. `PYTHONPATH=build/python
python3 scripts/contact_figures.py [ramp|stiff|drop|blob|tolerance|slide]`."""
import math, os, sys, time
import numpy as np
import opdeform
from opdeform import materials, meshes, scenes
from opdeform.simulation import frame_from_normal

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tests"))
from test_contact import _cube_on_a_ramp as cube_on_ramp  # the tests' cube on the ramp: (distance, degrees)
from test_contact import _suzanne_on_the_ramp

def cube():
    return scenes.RampCube(0.0, 24).graph

def rigid_error(sim, g):
    x = sim.positions; X = g.centers
    xc, Xc = x.mean(0), X.mean(0)
    H = (X - Xc).T @ (x - xc)
    u, s, vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    R = vt.T @ np.diag([1, 1, d]) @ u.T
    return np.abs((X - Xc) @ R.T + xc - x).max()

def stiff_capsule(where="floor", dt=1/24, its=10, seconds=3.0, mu=0.5):
    """The k = 1e15 capsule (0.6 m, 100 particles) set 5 mm above the floor or a plane: its worst distance from
    rigid (the Kabsch fit of its centres) over the second half of the run, and its length."""
    v, t = meshes.capsule(radius=0.1, length=0.4)
    g = opdeform.Graph.from_mesh(v, t, particles=100)
    sim = opdeform.Simulation(g, 1e15, dt=dt, iterations=its)
    lowest = (g.centers[:, 2] - np.sqrt(((g.radii * g.axes[:, 2, :]) ** 2).sum(axis=1))).min()
    sim.set_state(g.centers + (0, 0, 0.005 - lowest), np.tile(np.eye(3), (g.n_particles, 1, 1)))
    if where == "floor":
        sim.set_floor(0.0, mu)
    else:
        sim.add_collider("plane", normal=(0, 0, 1), friction=mu)
    worst = 0.0
    for k in range(int(seconds / dt)):
        sim.step()
        if k > seconds / dt / 2:
            worst = max(worst, rigid_error(sim, g))
    return worst, np.ptp(v, axis=0).max()

def drop(where="floor", h=1.0, fps=60):
    v, t = meshes.capsule(radius=0.2, length=0.2)
    g = opdeform.Graph.from_mesh(v, t, particles=100)
    sim = opdeform.Simulation(g, 3e4, dt=1 / fps)
    lowest = (g.centers[:, 2] - np.sqrt(((g.radii * g.axes[:, 2, :]) ** 2).sum(axis=1))).min()
    sim.set_state(g.centers + (0, 0, h - lowest), np.tile(np.eye(3), (g.n_particles, 1, 1)))
    if where == "floor":
        sim.set_floor(0.0)
    else:
        sim.add_collider("plane", normal=(0, 0, 1))
    z0 = sim.positions.mean(0)[2]
    zs = []
    for k in range(int(3 * fps)):
        sim.step()
        zs.append(sim.positions.mean(0)[2])
    zs = np.array(zs)
    i = zs.argmin()
    return (zs[i:].max() - zs[i]) / (z0 - zs[i])

def blob_on_sphere(seconds=(1, 2, 3, 5, 10), fps=24):
    """tests/test_addon_colliders.py's blob (60 particles, k = 1e5, undamped) dropped 0.3 m onto a unit sphere
    (mu = 0.5): the mean height of its shown vertices at each time (the test wants > 1.1 m at 2 s)."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    sys.path[:0] = [os.path.join(root, "addon"), os.path.join(root, "tests")]
    from opdeform_blender.core import colliders
    from test_addon_colliders import blob_engine, sphere_collider
    e, _ = blob_engine()
    e.configure(dict(e._params), end=max(seconds) * fps + 1)
    around = colliders.Surroundings((sphere_collider(),), ())
    heights = {}
    for f in range(1, max(seconds) * fps + 1):
        out = e.goto(f, surroundings=around)
        if f % fps == 0 and f // fps in seconds:
            heights[f // fps] = float(out[:, 2].mean())
    return heights

def pairs_under_tolerance(graph, mu, fps=24, seconds=2.0):
    """The Rubber cube on the 30-degree plane at its preset's tolerance (auto, 2e-5, at most 100 pairs): mean
    pairs a step and how many steps stopped at the most."""
    theta = math.radians(30.0)
    normal = np.array([0.0, -math.sin(theta), math.cos(theta)])
    frame = frame_from_normal(normal)
    sim = materials.make_simulation(graph, "Rubber", dt=1 / fps)
    lowest = (graph.centers[:, 2] - np.sqrt(((graph.radii * graph.axes[:, 2, :]) ** 2).sum(axis=1))).min()
    sim.set_state((graph.centers + (0.0, 0.0, 0.01 - lowest)) @ frame.T, np.tile(frame, (graph.n_particles, 1, 1)))
    sim.add_collider("plane", normal=normal, friction=mu)
    pairs = []
    for k in range(int(seconds * fps)):
        sim.step()
        pairs.append(sim.step_report["iterations"])
    return np.mean(pairs), sum(p >= sim.max_iterations for p in pairs), len(pairs)

def suzanne_pairs(particles=100, kind="sphere", frames=48):
    """Suzanne (tests/reference, subdivided twice) set 0.1 m above a mesh sphere (radius 1, 48 x 24) or a 30-degree
    plane, the add-on's defaults (15 MPa, 0.3/s damping, auto to 2e-5, at most 100 pairs, 24 fps): mean pairs a
    step without the collider, with it, and with it over the steps in contact only (a particle's centre within
    its largest radius and 5 cm of the collider; a Suzanne that rolls off a sphere falls freely at 2 pairs a step)
    and how many steps those are."""
    d = np.load(os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tests", "reference",
                             "suzanne_subdivided.npz"))
    v, t = d["vertices"] - d["vertices"].mean(axis=0), d["triangles"]
    g = opdeform.Graph.from_mesh(v, t, particles=particles)
    reach = g.radii.max(axis=1)
    if kind == "sphere":
        n, base = np.array([0.0, 0.0, 1.0]), 1.0
        sv, st = meshes.capsule(radius=1.0, length=0.0, segments=48, rings=24)
    else:
        n, base = np.array([math.sin(math.radians(30.0)), 0.0, math.cos(math.radians(30.0))]), 0.0
        sv, st = np.array([[-4, -4, 0], [4, -4, 0], [4, 4, 0], [-4, 4, 0]], float) @ frame_from_normal(n).T, [[0, 1, 2], [0, 2, 3]]
    lift = base + 0.1 - ((g.centers - reach[:, None] * n) @ n).min()
    out = []
    for collide in (False, True):
        sim = opdeform.Simulation(g, materials.stiffness_for(g, 15e6), dt=1 / 24, density=1000.0,
                                  damping=materials.step_damping(0.3, 1 / 24))
        sim.set_solver(accelerator=materials.DEFAULT_ACCELERATOR, tolerance=2e-5, max_iterations=100)
        sim.set_state(g.centers + lift * n, np.tile(np.eye(3), (g.n_particles, 1, 1)))
        if collide:
            sim.add_collider("mesh", vertices=sv, triangles=st, friction=0.5, thickness=0.02)
        pairs, touching = [], []
        for k in range(frames):
            sim.step()
            pairs.append(sim.step_report["iterations"])
            if collide:
                touching.append((sim.collider_distances(sim.positions) - reach).min() < 0.05)
        out.append(np.mean(pairs))
    touched = [p for p, c in zip(pairs, touching) if c]
    return (*out, np.mean(touched) if touched else float("nan"), len(touched), frames)

def suzanne_slide(rate, mu, particles=1000, seconds=2.0):
    """The Suzanne on the ramp: its centre's speed down the ramp at 0.6 s (landed), its acceleration from 1 s while
    its centre is 0.7 m or more from the ramp's lower rim, the friction coefficient that acceleration means, its
    contact patch's mean speed over its centre's then (1: sliding; below: rolling or tumbling), and in how many of
    those steps its skin is more than 1 cm off the ramp (hopping)."""
    rows = _suzanne_on_the_ramp(rate, mu, seconds, particles)
    t = np.arange(1, len(rows) + 1) / rate
    window = (t >= 1.0) & (rows[:, 1] < 3.3)
    a = np.polyfit(t[window], rows[window, 0], 1)[0]
    sin, cos = math.sin(math.radians(30.0)), math.cos(math.radians(30.0))
    return (rows[int(0.6 * rate) - 1, 0], a, 9.81 * (sin - mu * cos), (9.81 * sin - a) / (9.81 * cos),
            rows[window, 2].mean() / rows[window, 0].mean(), t[window].max(), (rows[window, 3] > 0.01).sum(),
            window.sum())

if __name__ == "__main__":
    what = sys.argv[1:] or ["ramp", "stiff", "drop", "blob", "tolerance", "slide"]
    g = cube()
    t0 = time.time()
    if "ramp" in what:
        for fps in (24, 60, 240):
            for mu in (1.0, 0.3):
                print(f"plane ramp fps {fps} mu {mu}: %.3f m, %.1f deg" % cube_on_ramp(g, mu, fps), flush=True)
    if "stiff" in what:
        for where in ("floor", "plane"):
            for dt in (1/24, 1/60, 1/240):
                e, size = stiff_capsule(where, dt)
                print(f"stiff capsule on {where} dt 1/{round(1/dt)}: {e*1000:.2f} mm ({100*e/size:.2f} % of {size:.2f} m)", flush=True)
    if "drop" in what:
        for where in ("floor", "plane"):
            print(f"drop on {where}: rebound {drop(where):.3f} of the drop", flush=True)
    if "blob" in what:
        print("blob on a sphere, mean height: " + ", ".join(f"{t} s {z:.3f} m" for t, z in blob_on_sphere().items()))
    if "tolerance" in what:
        for mu in (1.0, 0.3):
            print("cube on the ramp at the preset's tolerance, mu %.1f: %.1f pairs a step, %d of %d steps at the most" %
                  (mu, *pairs_under_tolerance(g, mu)))
        for kind in ("sphere", "ramp"):
            print("Suzanne, 100 particles, on a mesh %s at the add-on's defaults: %.1f pairs a step free, %.1f with it, "
                  "%.1f over the %d of %d steps in contact" % (kind, *suzanne_pairs(100, kind)))
    if "slide" in what:
        for particles in (1000, 100):
            for rate in (24, 60, 240):
                for mu in (0.3, 0.5):
                    print("Suzanne on the ramp, %d particles, %d Hz, mu %.1f: %.2f m/s at 0.6 s, then %.3f m/s2 (Coulomb "
                          "%.3f, mu' %.3f), its patch at %.2f of its centre's speed (1 s to %.2f s), off the ramp in %d "
                          "of %d steps" % (particles, rate, mu, *suzanne_slide(rate, mu, particles)), flush=True)
    print("%.1f s" % (time.time() - t0))
