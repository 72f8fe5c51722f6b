"""The character held by its torso as `scripts/bench calibration` holds it, solved as a voxel continuum (issue 24,
docs/settings.md "Calibration for any body"): linear elastic 8-node cubes (Poisson's ratio 0, as the continuum
frame's G = E / 2) on materials' grid of the closed mesh, Jelly's E at the body's size and its density, the grid
node nearest each held vertex fixed, gravity along -z. Prints, per grid (cells over the bounding box), the
droop of the left ear's and the tail's tip region over their lengths (the bench's rows), the head's mean drop and
the ear's axis root and tip drops (the bench's --parts). Linear cubes are too stiff in bending with few cells
across a part: the figures grow with the grid. Conjugate gradients, Jacobi preconditioned, numpy only: 50,000,
100,000 and 200,000 cells took 120 s of processor time together (94 MB).

    PYTHONPATH=build/python:scripts python3 scripts/character_continuum.py [CELLS ...]
"""

import sys

import numpy as np

import opdeform
from benchmarks import calibration as bench
from opdeform import meshes, materials

CORNERS = np.array([[i, j, k] for k in (0, 1) for j in (0, 1) for i in (0, 1)])


def cube_stiffness(e, h):
    """The 24 x 24 stiffness of a cube of side h (nodes CORNERS, x y z per node) at Young's modulus e and
    Poisson's ratio 0: 2 x 2 x 2 Gauss points."""
    d = np.diag([e, e, e, e / 2, e / 2, e / 2])  # nu = 0: lambda = 0, mu = e / 2 (engineering shear strains)
    out = np.zeros((24, 24))
    for p in np.stack(np.meshgrid(*[0.5 + np.array([-0.5, 0.5]) / np.sqrt(3)] * 3, indexing="ij"), -1).reshape(-1, 3):
        f = np.where(CORNERS == 1, p, 1 - p)  # (8, 3) the factors of each node's trilinear shape function
        sign = np.where(CORNERS == 1, 1.0, -1.0)
        grad = sign * np.stack([f[:, 1] * f[:, 2], f[:, 0] * f[:, 2], f[:, 0] * f[:, 1]], axis=1) / h
        b = np.zeros((6, 24))
        for axis, (i, j) in enumerate(((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))):
            b[axis, i::3] += grad[:, j]
            if i != j:
                b[axis, j::3] += grad[:, i]
        out += b.T @ d @ b * h ** 3 / 8
    return out


def nearest(nodes, points):
    """The index of the node nearest each point."""
    return np.array([np.argmin(((nodes - p) ** 2).sum(axis=1)) for p in points], dtype=np.int64)


def conjugate_gradients(apply, b, diagonal, rtol=1e-9, limit=50_000):
    """x with apply(x) = b (symmetric positive definite), Jacobi preconditioned, to |r| <= rtol |b|."""
    x = np.zeros_like(b)
    r = b.copy()
    z = r / diagonal
    p = z.copy()
    rz = r @ z
    for _ in range(limit):
        if np.linalg.norm(r) <= rtol * np.linalg.norm(b):
            return x
        q = apply(p)
        step = rz / (p @ q)
        x += step * p
        r -= step * q
        z = r / diagonal
        rz, last = r @ z, rz
        p = z + (rz / last) * p
    raise RuntimeError(f"conjugate gradients did not converge in {limit} iterations")


def solve(cells):
    """(node positions, node displacements) of the character on a grid of ``cells`` held as the bench holds it."""
    v, t, held = bench._character("tail")[:3]
    grid = materials._Grid(v, t, cells=cells)
    shape = np.array(grid.shape) + 1
    e = bench.JELLY.modulus * materials.body_size(opdeform.Graph.from_mesh(v, t)) / materials.REFERENCE_SIZE
    cubes = np.argwhere(grid.inside)
    flat = np.ravel_multi_index((cubes[:, None, :] + CORNERS[None]).reshape(-1, 3).T, shape)
    used, node = np.unique(flat, return_inverse=True)
    dof = (3 * node.reshape(-1, 8)[:, :, None] + np.arange(3)).reshape(-1, 24)
    n = 3 * len(used)
    k = cube_stiffness(e, grid.h)
    nodes = grid.lo + np.stack(np.unravel_index(used, shape), axis=1) * grid.h
    free = np.ones(n)
    free[(3 * np.unique(nearest(nodes, v[held]))[:, None] + np.arange(3)).ravel()] = 0.0

    def apply(x):  # the free rows and columns of the assembled stiffness times x
        return free * np.bincount(dof.ravel(), ((free * x)[dof] @ k).ravel(), minlength=n)
    load = free * np.bincount(dof[:, 2::3].ravel(), minlength=n) * -bench.JELLY.density * bench.G * grid.h ** 3 / 8
    diagonal = np.bincount(dof.ravel(), np.tile(np.diag(k), len(cubes)), minlength=n) * free + (1.0 - free)
    return nodes, conjugate_gradients(apply, load, diagonal).reshape(-1, 3)


def main():
    for cells in [int(c) for c in sys.argv[1:]] or [20_000, 50_000, 100_000]:
        nodes, u = solve(cells)
        droops = []
        for body in ("character_ear", "character_tail"):
            v, _, _, tip, length = bench.BODIES[body]()
            droops.append(-u[nearest(nodes, v[tip]), 2].mean() / length)
        head = np.mean(meshes.CHARACTER_PARTS["head"][:2], axis=0)
        root, end = -1e3 * u[nearest(nodes, meshes.CHARACTER_PARTS["ear.L"][:2]), 2]
        print(f"{cells} cells: ear {100 * droops[0]:.2f} %, tail {100 * droops[1]:.2f} %; head "
              f"{-1e3 * u[np.linalg.norm(nodes - head, axis=1) < 0.2, 2].mean():.2f} mm, ear.L's axis root "
              f"{root:.2f} mm, its tip {end:.2f} mm", flush=True)


if __name__ == "__main__":
    main()
