"""One timed MLS-MPM snow block, run in its own process by benchmarks/mpm.py:

    python -m benchmarks._mpm_runner ENGINE PER_AXIS N_GRID DT STEPS THREADS [FP]

ENGINE is `opdeform` or `taichi` (Taichi's mpm99 kernel extended to 3-D, FP f32 or f64). Both simulate the
same scene: a cube of PER_AXIS³ particles 2 per cell per axis in [0, 1]³ with N_GRID cells per axis,
falling at 1 m/s, the seed's snow (Table 2), gravity, the domain's faces stopping outward motion within
3 nodes, a fixed dt. Prints one JSON line: particles, steps, seconds and cpu_seconds (wall and processor time of
every thread of the process, after one warm-up step) and, for opdeform, the grid blocks in use, for Taichi its
version. Taichi's runs use the interpreter of the benchmark's own virtual environment (benchmarks/mpm.py).
"""

import json
import sys
import time

E, NU, RHO = 5e3, 0.3, 600.0


def block(per_axis, n_grid):
    """The particles' lattice: spacing dx/2, centred in x and y, bottom at z = 0.3."""
    spacing = 0.5 / n_grid
    lo = 0.5 - 0.5 * per_axis * spacing
    return spacing, lo


def run_opdeform(per_axis, n_grid, dt, steps, threads):
    import numpy as np

    from opdeform import mpm

    spacing, lo = block(per_axis, n_grid)
    a = (np.arange(per_axis) + 0.5) * spacing
    x, y, z = np.meshgrid(lo + a, lo + a, 0.3 + a, indexing="ij")
    pts = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    world = mpm.World((0, 0, 0), (1, 1, 1), 1.0 / n_grid, walls="separate", threads=threads)
    world.add_particles(pts, mpm.snow(), particle_volume=spacing ** 3,
                        velocities=np.broadcast_to([0.0, 0.0, -1.0], pts.shape))
    world.substep(dt)
    t, c = time.perf_counter(), time.process_time()
    for _ in range(steps):
        world.substep(dt)
    seconds, cpu = time.perf_counter() - t, time.process_time() - c
    return {"particles": len(pts), "steps": steps, "seconds": seconds, "cpu_seconds": cpu,
            "blocks": world.stats["active_blocks"]}


def run_taichi(per_axis, n_grid, dt, steps, threads, fp):
    import taichi as ti

    real = ti.f64 if fp == "f64" else ti.f32
    ti.init(arch=ti.cpu, default_fp=real, cpu_max_num_threads=threads, log_level=ti.ERROR, random_seed=0)
    spacing, lo = block(per_axis, n_grid)
    dx, inv_dx = 1.0 / n_grid, float(n_grid)
    n = per_axis ** 3
    p_vol = spacing ** 3
    p_mass = p_vol * RHO
    mu_0, lambda_0 = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))
    x = ti.Vector.field(3, real, n)
    v = ti.Vector.field(3, real, n)
    C = ti.Matrix.field(3, 3, real, n)
    F = ti.Matrix.field(3, 3, real, n)
    Jp = ti.field(real, n)
    grid_v = ti.Vector.field(3, real, (n_grid + 1,) * 3)
    grid_m = ti.field(real, (n_grid + 1,) * 3)

    @ti.kernel
    def init():
        for i in range(n):
            a, b, c = i % per_axis, (i // per_axis) % per_axis, i // (per_axis * per_axis)
            x[i] = ti.Vector([lo + (a + 0.5) * spacing, lo + (b + 0.5) * spacing, 0.3 + (c + 0.5) * spacing])
            v[i] = ti.Vector([0.0, 0.0, -1.0])
            F[i] = ti.Matrix.identity(real, 3)
            C[i] = ti.Matrix.zero(real, 3, 3)
            Jp[i] = 1.0

    @ti.kernel
    def substep():
        for I in ti.grouped(grid_m):
            grid_v[I] = ti.Vector.zero(real, 3)
            grid_m[I] = 0.0
        for p in x:
            base = (x[p] * inv_dx - 0.5).cast(int)
            fx = x[p] * inv_dx - base.cast(real)
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2]
            F[p] = (ti.Matrix.identity(real, 3) + dt * C[p]) @ F[p]
            U, sig, V = ti.svd(F[p])
            J = 1.0
            for d in ti.static(range(3)):
                new_sig = ti.min(ti.max(sig[d, d], 1 - 2.5e-2), 1 + 4.5e-3)
                Jp[p] *= sig[d, d] / new_sig
                sig[d, d] = new_sig
                J *= new_sig
            F[p] = U @ sig @ V.transpose()
            h = ti.exp(10 * (1.0 - Jp[p]))
            mu, la = mu_0 * h, lambda_0 * h
            stress = 2 * mu * (F[p] - U @ V.transpose()) @ F[p].transpose() + ti.Matrix.identity(real, 3) * la * J * (
                J - 1)
            affine = (-dt * p_vol * 4 * inv_dx * inv_dx) * stress + p_mass * C[p]
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                offset = ti.Vector([i, j, k])
                dpos = (offset.cast(real) - fx) * dx
                weight = w[i][0] * w[j][1] * w[k][2]
                grid_v[base + offset] += weight * (p_mass * v[p] + affine @ dpos)
                grid_m[base + offset] += weight * p_mass
        for I in ti.grouped(grid_m):
            if grid_m[I] > 0:
                grid_v[I] = grid_v[I] / grid_m[I] + dt * ti.Vector([0.0, 0.0, -9.81])
                for d in ti.static(range(3)):
                    if I[d] < 3 and grid_v[I][d] < 0:
                        grid_v[I][d] = 0
                    if I[d] > n_grid - 3 and grid_v[I][d] > 0:
                        grid_v[I][d] = 0
        for p in x:
            base = (x[p] * inv_dx - 0.5).cast(int)
            fx = x[p] * inv_dx - base.cast(real)
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]
            new_v = ti.Vector.zero(real, 3)
            new_C = ti.Matrix.zero(real, 3, 3)
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                dpos = ti.Vector([i, j, k]).cast(real) - fx
                g_v = grid_v[base + ti.Vector([i, j, k])]
                weight = w[i][0] * w[j][1] * w[k][2]
                new_v += weight * g_v
                new_C += 4 * inv_dx * weight * g_v.outer_product(dpos)
            v[p], C[p] = new_v, new_C
            x[p] += dt * v[p]

    init()
    substep()  # compiles
    ti.sync()
    t, c = time.perf_counter(), time.process_time()
    for _ in range(steps):
        substep()
    ti.sync()
    return {"particles": n, "steps": steps, "seconds": time.perf_counter() - t, "cpu_seconds": time.process_time() - c,
            "version": ".".join(str(part) for part in ti.__version__)}


def main(argv):
    engine, per_axis, n_grid, dt, steps, threads = argv[0], int(argv[1]), int(argv[2]), float(argv[3]), int(
        argv[4]), int(argv[5])
    if engine == "opdeform":
        result = run_opdeform(per_axis, n_grid, dt, steps, threads)
    else:
        result = run_taichi(per_axis, n_grid, dt, steps, threads, argv[6] if len(argv) > 6 else "f64")
    print(json.dumps(result))


if __name__ == "__main__":
    main(sys.argv[1:])
