"""Issue 27's Suzannes as added (docs/contact.md, "Stacks as a new user sets them up"), as rigid bodies: the tilt
at which Blender's Suzanne (507 vertices), stood on its chin as tests/blender/suite_colliders.py's suzanne_pair
stands it, rests as a rigid body (the nearest minimum, over turns about x, of the height of its centre of mass, the
mesh's volume centroid, or its vertices' mean), then the same pair, the upper dropped 1 m, in Blender's own rigid
body simulation (Bullet) on a passive plane, per collision shape and Coulomb mu (each body's Friction sqrt(mu):
Bullet multiplies the two):

    blender -b --factory-startup --python-exit-code 1 -P scripts/rigid_monkeys.py -- [SHAPES [MUS]]
        (CONVEX_HULL,MESH and 0.5,1.0)

Prints the rest tilt, then per shape and mu the lower's tilt and the upper's centre aside of the lower's and above
its highest vertex (m) at 1, 3 and 13 s.
"""

import math
import os
import sys

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tests", "blender"))
import helpers as H  # noqa: E402
import suite_colliders as S  # noqa: E402

SECONDS = (1, 3, 13)


def centres(obj):
    """The mesh's volume centroid (its triangles' signed tetrahedra from the origin) and its vertices' mean."""
    v = np.array([p.co[:] for p in obj.data.vertices])
    tris = np.array([(f.vertices[0], f.vertices[k], f.vertices[k + 1]) for f in obj.data.polygons
                     for k in range(1, len(f.vertices) - 1)])
    t = v[tris]
    six = np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2]))
    return v, {"volume centroid": (t.sum(axis=1) / 4.0 * six[:, None]).sum(axis=0) / six.sum(),
               "vertices' mean": v.mean(axis=0)}


def rest_tilt(v, centre):
    """Degrees about x to the nearest minimum of the centre's height above the lowest vertex."""
    def height(deg):
        c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
        turn = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
        return (turn @ centre)[2] - (v @ turn.T)[:, 2].min()
    sides = []
    for step in (1, -1):
        deg = 0
        while height(deg + step) < height(deg):
            deg += step
        sides.append(deg)
    return min(sides, key=lambda d: height(d))


def rigid_pair(shape, mu):
    """The pair on a passive plane, lower at rest on its chin, each body's Friction sqrt(mu): (lower, upper)."""
    H.fresh()
    bpy.ops.mesh.primitive_plane_add(size=20.0)
    bodies = [bpy.context.active_object, *S.placed_suzannes(0, 0.0)]
    for obj in bodies:
        bpy.context.view_layer.objects.active = obj
        bpy.ops.rigidbody.object_add()
        obj.rigid_body.friction = math.sqrt(mu)
        obj.rigid_body.collision_shape = shape if obj is not bodies[0] else 'MESH'
    bodies[0].rigid_body.type = 'PASSIVE'
    return bodies[1:]


def play(low, high):
    scene = bpy.context.scene
    scene.frame_end = scene.rigidbody_world.point_cache.frame_end = SECONDS[-1] * H.FPS
    cells = []
    for f in range(1, SECONDS[-1] * H.FPS + 1):
        scene.frame_set(f)
        if f % H.FPS == 0 and f // H.FPS in SECONDS:
            above, aside = S.stack_figures(S.world(low), S.world(high))
            tilt = math.degrees(low.matrix_world.to_euler().x)
            cells.append(f"{f // H.FPS} s: tilt {tilt:.1f}, aside {aside:.3f}, above {above:.3f}")
    return "; ".join(cells)


def main(argv):
    shapes = (argv[0] if argv else "CONVEX_HULL,MESH").split(",")
    mus = [float(m) for m in (argv[1] if len(argv) > 1 else "0.5,1.0").split(",")]
    H.fresh()
    v, found = centres(S.placed_suzannes(0, 0.0)[0])
    for name, centre in found.items():
        print(f"rest tilt (centre of mass: the {name}, {np.round(centre, 3)} m): {rest_tilt(v, centre)} deg",
              flush=True)
    for shape in shapes:
        for mu in mus:
            print(f"rigid {shape} mu {mu}: {play(*rigid_pair(shape, mu))}", flush=True)


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
