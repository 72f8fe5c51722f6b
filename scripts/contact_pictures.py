"""Pictures of contact (docs/contact.md, issue 13), rendered with matplotlib from the simulations themselves:
a bar dropped on another at rest on it (a ContactGroup), a tail pulled onto its own body (self-contact), a blob
sliding down a 30-degree ramp with and without friction, a box on that ramp at one step a frame (24 fps) holding
and sliding, soft spheres and creatures stacked, and wind pushing a blob along a floor. Each scene runs
here (a few seconds of CPU); the skinned meshes are drawn as flat-shaded triangles, sorted back to front.

Usage: PYTHONPATH=build/python python3 scripts/contact_pictures.py [OUT_DIR]   (default docs/images)
"""

import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402

import opdeform  # noqa: E402
from opdeform import meshes, scenes  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from benchmarks import stacking  # noqa: E402  (the stacking benchmark's bodies)

LIGHT = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])


def view(azimuth, elevation):
    """World -> (right, up, depth towards the viewer) for a camera at the given angles (degrees)."""
    a, e = math.radians(azimuth), math.radians(elevation)
    turn = np.array([[math.cos(a), math.sin(a), 0.0], [-math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])
    tilt = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(e), math.sin(e)], [0.0, -math.sin(e), math.cos(e)]])
    return (tilt @ turn)[[0, 2, 1]] * np.array([[1.0], [1.0], [-1.0]])


def draw_mesh(ax, vertices, triangles, colour, camera, alpha=1.0):
    """Flat-shaded triangles of a mesh, projected by `camera` (view()), painted back to front."""
    p = vertices @ camera.T
    tri = vertices[triangles]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True) + 1e-300
    facing = (normal @ camera[2]) < 0.0  # towards the viewer (depth axis points away)
    shade = 0.35 + 0.65 * np.abs(normal @ LIGHT)
    order = np.argsort((p[triangles][:, :, 2]).mean(axis=1))[::-1]
    order = order[facing[order]]
    faces = p[triangles[order]][:, :, :2]
    colours = np.clip(np.asarray(colour)[None, :] * shade[order, None], 0.0, 1.0)
    ax.add_collection(PolyCollection(faces, facecolors=colours, edgecolors=colours, linewidths=0.2, alpha=alpha))


def draw_plane(ax, point, normal, size, camera, colour=(0.8, 0.8, 0.8)):
    """A square of the plane through `point` with unit `normal`, `size` m a side."""
    n = np.asarray(normal, float)
    u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    w = np.cross(n, u)
    corners = np.array([point + size / 2 * (su * u + sw * w) for su, sw in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
    ax.add_collection(PolyCollection([(corners @ camera.T)[:, :2]], facecolors=[colour], edgecolors="0.6"))


def finish(ax, title, points, camera, pad=0.1):
    p = np.concatenate(points) @ camera.T
    ax.set_xlim(p[:, 0].min() - pad, p[:, 0].max() + pad)
    ax.set_ylim(p[:, 1].min() - pad, p[:, 1].max() + pad)
    ax.set_aspect("equal")
    ax.set_axis_off()
    ax.set_title(title, fontsize=9)


def stack(out):
    """Two 0.6 m bars (100 particles, k = 1e6), the upper dropped 0.15 m onto the lower, μ = 0.5, at 0, 0.5 and
    10 s (a pair starting or stopping to press jolts it briefly: 0.12 m/s at 6 s)."""
    v, t = meshes.bar(length=0.6, width=0.3, segments=12, cross=4)
    v = v - v.mean(axis=0)
    g = opdeform.Graph.from_mesh(v, t, particles=100)
    sims = []
    for lift in (0.0, 0.45):
        sim = opdeform.Simulation(g, 1e6, dt=1 / 60, gravity=(0, 0, -9.81))
        sim.set_state(g.centers + (0.0, 0.0, lift), np.tile(np.eye(3), (g.n_particles, 1, 1)))
        sim.set_floor(-0.15, 0.5)
        sims.append(sim)
    group = opdeform.ContactGroup(sims, friction=0.5)
    skin = opdeform.Skin(g, v)
    camera = view(-30, 15)
    fig, axes = plt.subplots(1, 3, figsize=(9, 3.2))
    done = 0
    for ax, seconds in zip(axes, (0.0, 0.5, 10.0)):
        if round(seconds * 60) > done:
            group.step(round(seconds * 60) - done)
            done = round(seconds * 60)
        shown = [skin.deform_sim(sim) for sim in sims]
        draw_plane(ax, np.array([0.0, 0.0, -0.15]), (0, 0, 1), 1.2, camera)
        for vertices, colour in zip(shown, ((0.45, 0.6, 0.85), (0.9, 0.55, 0.35))):
            draw_mesh(ax, vertices, t, colour, camera)
        speed = max(np.abs(sim.velocities).max() for sim in sims)
        finish(ax, f"t = {seconds:.1f} s, fastest particle {speed:.3f} m/s", shown, camera)
    fig.suptitle("A bar dropped on another comes to rest on it (ContactGroup, μ = 0.5)", fontsize=10)
    save(fig, out, "contact_stack.png")


def tail(out):
    """A 1.2 m rod held at its root, the pin on its tip carried round onto the root, with and without
    self-contact (tests/test_body_contact.py)."""
    camera = view(0, 10)
    fig, axes = plt.subplots(1, 2, figsize=(8, 3.6))
    for ax, self_contact in zip(axes, (False, True)):
        sim, v, t, tip, targets = scenes.bent_rod(self_contact)
        for target in targets:
            sim.set_constraint_target(tip, target)
            sim.step()
        g = sim.graph
        shown = opdeform.Skin(g, v).deform_sim(sim)
        draw_mesh(ax, shown, t, (0.55, 0.75, 0.5) if self_contact else (0.8, 0.5, 0.5), camera, alpha=0.85)
        finish(ax, "self-contact on: the tip rests on the root" if self_contact else
               "self-contact off: the tip passes into the root", [shown], camera)
    fig.suptitle("A tail pulled onto its own body (pin on the tip carried round to the root)", fontsize=10)
    save(fig, out, "contact_tail.png")


def ramp(out):
    """A blob (0.6 m capsule, 100 particles) on a 30-degree plane, frictionless and with μ = 0.3: where it is
    at 0, 0.25 and 0.5 s (tests/test_contact.py)."""
    v, t = meshes.capsule(radius=0.2, length=0.2)
    g = opdeform.Graph.from_mesh(v, t, particles=100)
    angle = math.radians(30.0)
    normal = np.array([0.0, -math.sin(angle), math.cos(angle)])
    camera = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])  # from the side: downhill to the right
    downhill = np.array([0.0, -math.cos(angle), -math.sin(angle)])
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    for ax, mu in zip(axes, (0.0, 0.3)):
        sim = opdeform.Simulation(g, 3e4, dt=1 / 60)
        sim.set_state(g.centers + normal * 0.21 - g.centers.mean(axis=0), np.tile(np.eye(3), (g.n_particles, 1, 1)))
        sim.add_collider("plane", normal=tuple(normal), friction=mu)
        skin = opdeform.Skin(g, v)
        start, shown = sim.positions.mean(axis=0), []
        ends = np.array([-0.5 * downhill, 1.2 * downhill]) @ camera.T
        ground = [ends[0, :2], ends[1, :2], (ends[1, 0], ends[1, 1] - 0.15), (ends[0, 0], ends[1, 1] - 0.15)]
        ax.add_collection(PolyCollection([ground], facecolors=["0.85"], edgecolors="0.6"))
        for steps, shade in ((0, 0.45), (15, 0.7), (15, 1.0)):
            sim.step(steps) if steps else None
            shown.append(skin.deform_sim(sim))
            draw_mesh(ax, shown[-1], t, np.array([0.35, 0.55, 0.9]) * shade + (1 - shade) * 0.9, camera, alpha=0.9)
        moved = -(sim.positions.mean(axis=0) - start)[1] / math.cos(angle)
        expected = 0.5 * 9.81 * (math.sin(angle) - mu * math.cos(angle)) * 0.25
        finish(ax, f"μ = {mu}: {moved:.3f} m in 0.5 s (g (sin θ − μ cos θ) t²/2 = {expected:.3f})", shown, camera,
               pad=0.3)
    fig.suptitle("A blob sliding down a 30° ramp, at 0, 0.25 and 0.5 s (light to dark)", fontsize=10)
    save(fig, out, "contact_ramp.png")


def box_ramp(out):
    """Issue 27's 0.3 m Rubber cube on a 30-degree plane at one step a frame (1/24 s), μ = 1 and μ = 0.3:
    where it is at 0, 1 and 2 s (scenes.RampCube; tests/test_contact.py)."""
    camera = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])  # from the side: downhill to the right
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.4), gridspec_kw={"width_ratios": (1, 3)})
    for ax, mu, length in zip(axes, (1.0, 0.3), (0.6, 4.6)):
        scene = scenes.RampCube(mu, 24)
        downhill = np.cross((1.0, 0.0, 0.0), scene.normal)
        centre = scene.start.mean(axis=0)
        foot = centre - (centre @ scene.normal) * scene.normal - 0.3 * downhill  # the plane passes through 0
        ends = np.array([foot, foot + length * downhill]) @ camera.T
        ground = [ends[0, :2], ends[1, :2], (ends[1, 0], ends[1, 1] - 0.2), (ends[0, 0], ends[1, 1] - 0.2)]
        ax.add_collection(PolyCollection([ground], facecolors=["0.85"], edgecolors="0.6"))
        shown = []
        for frames, shade in ((0, 0.45), (24, 0.7), (24, 1.0)):
            scene.sim.step(frames) if frames else None
            shown.append(scene.skin.deform_sim(scene.sim))
            draw_mesh(ax, shown[-1], scene.triangles, np.array([0.85, 0.45, 0.3]) * shade + (1 - shade) * 0.9,
                      camera, alpha=0.9)
        moved, turned = scene.moved()
        finish(ax, f"μ = {mu:g}: {moved:.3f} m and {turned:.1f}° in 2 s", shown, camera, pad=0.15)
        ax.set_xlim(ends[:, 0].min() - 0.1, ends[:, 0].max() + 0.1)
        ax.set_ylim(ends[:, 1].min() - 0.3, ends[:, 1].max() + 0.4)
    fig.suptitle("A 0.3 m box on a 30° ramp at 24 fps, one step a frame: at 0, 1 and 2 s (light to dark)",
                 fontsize=10)
    save(fig, out, "contact_box_ramp.png")


def soft_stacks(out):
    """Soft bodies dropped onto like ones (the stacking benchmark's scenes, `scripts/bench stacking --stacks`):
    Rubber spheres and Rubber creatures, 100 particles each, μ = 0.5, at 0, 1 and 13 s."""
    sphere = meshes.capsule(radius=0.3, length=1e-3, segments=24, rings=8, body=1)
    cases = (("Rubber spheres", sphere[0] + (0.0, 0.0, 0.3), sphere[1], 0.7),
             ("Rubber creatures", *meshes.creature(24), 1.06))
    camera = view(-25, 12)
    fig, axes = plt.subplots(2, 3, figsize=(9, 6.4))
    for row, (name, v, t, lift) in zip(axes, cases):
        sims = [stacking.preset_body(v, t, 0.0, "Rubber"), stacking.preset_body(v, t, lift, "Rubber")]
        group = opdeform.ContactGroup(sims, friction=0.5)
        skins = [opdeform.Skin(sim.graph, v + (0.0, 0.0, z)) for sim, z in zip(sims, (0.0, lift))]
        done = 0
        for ax, seconds in zip(row, (0, 1, 13)):
            group.step(60 * (seconds - done)) if seconds > done else None
            done = seconds
            shown = [skin.deform_sim(sim) for skin, sim in zip(skins, sims)]
            draw_plane(ax, np.array([0.0, 0.0, 0.0]), (0, 0, 1), 1.6, camera)
            for vertices, colour in zip(shown, ((0.45, 0.6, 0.85), (0.9, 0.55, 0.35))):
                draw_mesh(ax, vertices, t, colour, camera)
            speed = np.abs(sims[1].velocities).max()
            finish(ax, f"{name}, {seconds} s\nupper's fastest particle {speed:.3f} m/s", shown, camera)
    fig.suptitle("Soft bodies dropped onto like ones rest on top (ContactGroup, μ = 0.5)", fontsize=10)
    save(fig, out, "contact_soft_stacks.png")


def wind(out):
    """A blob on a floor (μ = 0.3) in a wind of 6 m/s² along +x with drag 1/s: at 0, 0.5, 1 and 1.5 s."""
    v, t = meshes.capsule(radius=0.2, length=0.2)
    g = opdeform.Graph.from_mesh(v, t, particles=100)
    sim = opdeform.Simulation(g, 3e4, dt=1 / 60)
    sim.set_state(g.centers - g.centers.mean(axis=0) + (0.0, 0.0, 0.2), np.tile(np.eye(3), (g.n_particles, 1, 1)))
    sim.set_floor(0.0, 0.3)
    sim.step(30)  # settled on the floor
    sim.add_force_field("wind", strength=6.0, direction=(1.0, 0.0, 0.0), drag=1.0)
    skin = opdeform.Skin(g, v)
    camera = view(-20, 15)
    fig, ax = plt.subplots(figsize=(9, 3.0))
    shown = []
    for k, shade in enumerate((0.4, 0.6, 0.8, 1.0)):
        sim.step(30) if k else None
        shown.append(skin.deform_sim(sim))
    draw_plane(ax, np.array([1.0, 0.0, 0.0]), (0, 0, 1), 3.0, camera)
    for mesh, shade in zip(shown, (0.4, 0.6, 0.8, 1.0)):
        draw_mesh(ax, mesh, t, np.array([0.9, 0.5, 0.3]) * shade + (1 - shade) * 0.9, camera, alpha=0.9)
    ax.annotate("", xy=(0.9, 0.85), xytext=(0.7, 0.85), xycoords="axes fraction",
                arrowprops=dict(arrowstyle="->", lw=2, color="0.3"))
    ax.text(0.8, 0.9, "wind", transform=ax.transAxes, ha="center", fontsize=9)
    speed = sim.velocities.mean(axis=0)[0]
    finish(ax, f"at 0, 0.5, 1 and 1.5 s (light to dark); {speed:.2f} m/s at 1.5 s", shown, camera, pad=0.2)
    fig.suptitle("Wind (6 m/s² along x, drag 1/s) pushing a blob along a floor (μ = 0.3)", fontsize=10)
    save(fig, out, "contact_wind.png")


def save(fig, out, name):
    path = os.path.join(out, name)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(path)


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "docs", "images")
    os.makedirs(out, exist_ok=True)
    for scene in (stack, tail, ramp, box_ramp, soft_stacks, wind):
        scene(out)


if __name__ == "__main__":
    main()
