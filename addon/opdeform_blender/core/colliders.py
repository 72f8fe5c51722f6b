"""Scene colliders of one Engine, free of bpy: what Blender's Collision modifiers become, checked before anything
changes, and kept in step with the simulation's colliders (``Simulation.add_collider`` and friends, see
docs/contact.md) frame by frame.

A frame's colliders are a tuple of ``ColliderFrame`` (sorted by name): the evaluated mesh in the object's frame
(its scale applied once, so the frame is a rotation and a translation), friction, thickness and the sampling
resolution. ``SceneColliders`` moves the simulation's colliders to the next frame's (``move_collider``, and
``update_collider_vertices`` for a mesh that deformed), and places them anew (remove all, add all in order)
when the set changes or the solver jumps to a cached frame: the colliders' frames before a step are then a
function of the frame alone, so a bake equals playback bit for bit.
"""

from collections import namedtuple

import numpy as np

from .tumbling import split_matrix

STATIC_RESOLUTION = 64  # distance samples along a collider's longest side (docs/contact.md)
DEFORMING_RESOLUTION = 32  # a collider re-sampled every frame: 32 ms instead of 71 ms for 3,744 triangles


class ColliderError(ValueError):
    """Bad collider or force field from the scene: a message naming the object."""


ColliderFrame = namedtuple("ColliderFrame", "name vertices triangles rotation translation friction thickness "
                                            "resolution")
Surroundings = namedtuple("Surroundings", "colliders fields")  # one frame's colliders and force fields
NOTHING = Surroundings((), ())


def open_mesh_wound_against(triangles):
    """True when an open mesh has a face wound against its neighbour (an edge run the same way twice): its
    inside (behind the faces) is undefined. A closed mesh (every edge in two faces) may be wound either way."""
    directed = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    undirected = np.sort(directed, axis=1)
    _, counts = np.unique(undirected, axis=0, return_counts=True)
    if np.all(counts == 2):
        return False
    return len(np.unique(directed, axis=0)) < len(directed)


def check_mesh(name, vertices, triangles):
    if len(triangles) == 0:
        raise ColliderError(f"collider {name!r} has no faces: a Collision modifier needs a mesh with faces")
    if not np.all(np.isfinite(vertices)):
        raise ColliderError(f"collider {name!r} has non-finite (NaN or infinite) vertices")
    if open_mesh_wound_against(triangles):
        raise ColliderError(f"collider {name!r} is an open mesh with inconsistent normals (a face wound against "
                            "its neighbours): Mesh > Normals > Recalculate Outside")


def collider_frame(name, vertices, triangles, matrix, friction, thickness, resolution=STATIC_RESOLUTION,
                   mesh_checked=False):
    """A ColliderFrame from an object's local vertices (V, 3), triangles (T, 3) and 4x4 world matrix;
    ColliderError naming the object on bad input (the mesh's checks skipped when already passed)."""
    vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    triangles = np.asarray(triangles, dtype=np.int32).reshape(-1, 3)
    matrix = np.asarray(matrix, dtype=np.float64).reshape(4, 4)
    if not mesh_checked:
        check_mesh(name, vertices, triangles)
    if not (np.all(np.isfinite(matrix)) and abs(np.linalg.det(matrix[:3, :3])) > 1e-12):
        raise ColliderError(f"collider {name!r}: its transform is degenerate or not finite")
    if not (np.isfinite(thickness) and thickness > 0.0):
        raise ColliderError(f"collider {name!r}: thickness {thickness} must be > 0")
    if not (np.isfinite(friction) and friction >= 0.0):
        raise ColliderError(f"collider {name!r}: friction {friction} must be >= 0")
    rotation, stretch, translation = split_matrix(matrix)
    if np.allclose(stretch, np.eye(3), rtol=0.0, atol=1e-6):
        stretch = np.eye(3)  # unscaled (to float32's precision): the vertices exactly, a flat mesh stays flat
    return ColliderFrame(name, vertices @ stretch.T, triangles, rotation, translation, float(friction),
                         float(thickness), int(resolution))


class ColliderReader:
    """Each collider's last input and ColliderFrame: the same input gives the same record (its arrays the same
    objects, so comparing frames costs nothing), a mesh seen before skips its checks."""

    def __init__(self):
        self.seen = {}

    def frame(self, name, vertices, triangles, matrix, friction, thickness, resolution):
        inputs = (np.asarray(matrix, dtype=np.float64), float(friction), float(thickness), int(resolution))
        last = self.seen.get(name)
        mesh_same = last is not None and np.array_equal(last[0], vertices) and np.array_equal(last[1], triangles)
        if mesh_same and np.array_equal(last[2][0], inputs[0]) and last[2][1:] == inputs[1:]:
            return last[3]
        out = collider_frame(name, vertices, triangles, *inputs, mesh_checked=mesh_same)
        if mesh_same:
            out = out._replace(vertices=last[3].vertices, triangles=last[3].triangles) \
                if np.array_equal(out.vertices, last[3].vertices) else out._replace(triangles=last[3].triangles)
        self.seen[name] = (vertices, triangles, inputs, out)
        return out


def same_shape(a, b):
    """Whether two frames of a collider share the mesh's topology and sampling (only the vertices may differ)."""
    return (a.name == b.name and a.resolution == b.resolution and len(a.vertices) == len(b.vertices)
            and (a.triangles is b.triangles or np.array_equal(a.triangles, b.triangles)))


def same_vertices(a, b):
    return a.vertices is b.vertices or np.array_equal(a.vertices, b.vertices)


def same_frame(a, b):
    return (same_shape(a, b) and same_vertices(a, b) and np.array_equal(a.rotation, b.rotation)
            and np.array_equal(a.translation, b.translation) and (a.friction, a.thickness) == (b.friction,
                                                                                               b.thickness))


def same_surroundings(a, b):
    return (len(a.colliders) == len(b.colliders) and a.fields == b.fields
            and all(same_frame(p, q) for p, q in zip(a.colliders, b.colliders)))


def _blend_rotation(a, b, u):
    u_, _, vt = np.linalg.svd((1.0 - u) * a + u * b)
    if np.linalg.det(u_ @ vt) < 0:
        u_[:, -1] *= -1.0
    return u_ @ vt


def blend(a, b, u):
    """The surroundings of a frame skipped by a jump, a share u of the way from a to b: collider frames and
    vertices linearly (rotations made proper again), fields and any changed set as b's. A collider that did not
    move stays as it is, to the bit (blended, its re-sampled distances differ in the last bits, and contact
    inside the iterations carries that into the frames a jump simulates: tests/test_addon_colliders.py)."""
    if len(a.colliders) != len(b.colliders) or not all(same_shape(p, q) for p, q in zip(a.colliders, b.colliders)):
        return b
    return Surroundings(tuple(q if _still(p, q) else
                              q._replace(vertices=(1.0 - u) * p.vertices + u * q.vertices,
                                         rotation=_blend_rotation(p.rotation, q.rotation, u),
                                         translation=(1.0 - u) * p.translation + u * q.translation)
                              for p, q in zip(a.colliders, b.colliders)), b.fields)


def _still(p, q):
    return all(np.array_equal(getattr(p, k), getattr(q, k)) for k in ("vertices", "rotation", "translation"))


class Kept:
    """What keeps a solver's colliders or fields (``current``, None: unknown) in step with the scene's: a call on
    the solver for one of them, its ValueError a ColliderError naming it."""
    what = "collider"
    current = ()

    def _call(self, item, fn, *args, **kw):
        try:
            return fn(*args, **kw)
        except ValueError as exc:
            self.current = None  # partly changed: placed anew next time
            raise ColliderError(f"{self.what} {item.name!r}: {exc}") from None


class SceneColliders(Kept):
    """The simulation's colliders as the scene's, and the surroundings each simulated frame had (what a restore
    of that frame places again)."""

    def __init__(self, sim):
        self.sim = sim
        self.ids = []
        self.current = ()  # the colliders the simulation holds now (at the end of its last step)
        self.history = {}  # frame -> Surroundings

    def place(self, colliders):
        """Removes every collider and adds these where they are (no sweep: a teleport)."""
        for cid in self.ids:
            self.sim.remove_collider(cid)
        self.ids, self.current = [], ()
        for c in colliders:
            self.ids.append(self._call(c, self.sim.add_collider, "mesh", vertices=c.vertices, triangles=c.triangles,
                                       rotation=c.rotation, translation=c.translation, friction=c.friction,
                                       thickness=c.thickness, resolution=c.resolution))
        self.current = tuple(colliders)

    def move(self, colliders):
        """The colliders' frames at the end of the next step: moved (and re-sampled when deformed) while the
        set is the same, else placed there."""
        if self.current is None or len(colliders) != len(self.current) or \
                not all(same_shape(a, b) for a, b in zip(self.current, colliders)):
            self.place(colliders)
            return
        for cid, was, c in zip(self.ids, self.current, colliders):
            if not same_vertices(was, c):
                self._call(c, self.sim.update_collider_vertices, cid, c.vertices)
            if (was.friction, was.thickness) != (c.friction, c.thickness):
                self._call(c, self.sim.set_collider_contact, cid, c.friction, c.thickness)
            self._call(c, self.sim.move_collider, cid, c.translation, c.rotation)
        self.current = tuple(colliders)

    def remember(self, frame, surroundings):
        self.history[frame] = surroundings

    def at(self, frame, default):
        return self.history.get(frame, default)

    def outdated(self, frame, surroundings):
        """Whether a simulated frame had other surroundings than the scene has now (a collider or field moved
        by hand, a setting changed): its cached state and those after it are outdated."""
        before = self.history.get(frame)
        return before is not None and not same_surroundings(before, surroundings)


def contact_points(sim, positions, radii, margin=1.5):
    """The particle centres whose ellipsoid is near or inside a collider (signed distance below margin times
    its largest radius): what the overlay marks."""
    if sim is None or sim.n_colliders == 0:
        return positions[:0]
    near = sim.collider_distances(positions) < margin * radii.max(axis=1)
    return positions[near]
