"""Taichi 1.7.4 on the CPU: the substep of Taichi's `mpm99.py` example (MLS-MPM, quadratic
B-splines, the affine APIC velocity, fixed-corotated elasticity) with every particle the elastic
material, without its hardening factor, gravity or plasticity, in f64, on the block of
block.py. Run by peers.py, one process per thread count (Taichi fixes its threads at
`ti.init`):

    python taichi_mls.py --particles 100000 --dimension 2 --threads 1 --steps 50

prints one JSON line: particle-steps per second of the timed steps (after one warm-up step that
compiles the kernels), the particles, and the block's mean position and kinetic energy after
them."""

import argparse
import json
import time

import numpy as np
import taichi as ti

from block import Block, summary


def simulate(block, threads, steps):
    ti.init(arch=ti.cpu, cpu_max_num_threads=threads, default_fp=ti.f64, random_seed=0)
    d = block.dimension
    n = block.count
    nodes = block.grid_cells + 1
    dx, inv_dx = 0.01, 100.0
    dt = block.time_step()
    mass, volume = block.particle_mass, block.particle_volume
    mu, lam = block.mu, block.lam
    x = ti.Vector.field(d, dtype=ti.f64, shape=n)
    v = ti.Vector.field(d, dtype=ti.f64, shape=n)
    affine = ti.Matrix.field(d, d, dtype=ti.f64, shape=n)
    gradient = ti.Matrix.field(d, d, dtype=ti.f64, shape=n)
    grid_v = ti.Vector.field(d, dtype=ti.f64, shape=(nodes,) * d)
    grid_m = ti.field(dtype=ti.f64, shape=(nodes,) * d)
    bound = 3

    @ti.kernel
    def substep():
        for I in ti.grouped(grid_m):
            grid_v[I] = ti.zero(grid_v[I])
            grid_m[I] = 0.0
        # Particle to grid: the stress folded into the affine momentum (MLS).
        for p in x:
            base = (x[p] * inv_dx - 0.5).cast(int)
            fx = x[p] * inv_dx - base.cast(ti.f64)
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]
            gradient[p] = (ti.Matrix.identity(ti.f64, d) + dt * affine[p]) @ gradient[p]
            U, sig, V = ti.svd(gradient[p])
            J = 1.0
            for a in ti.static(range(d)):
                J *= sig[a, a]
            stress = 2.0 * mu * (gradient[p] - U @ V.transpose()) @ gradient[
                p
            ].transpose() + ti.Matrix.identity(ti.f64, d) * lam * J * (J - 1.0)
            stress = (-dt * volume * 4.0 * inv_dx * inv_dx) * stress
            momentum_affine = stress + mass * affine[p]
            for offset in ti.static(ti.grouped(ti.ndrange(*((3,) * d)))):
                dpos = (offset.cast(ti.f64) - fx) * dx
                weight = 1.0
                for a in ti.static(range(d)):
                    weight *= w[offset[a]][a]
                grid_v[base + offset] += weight * (mass * v[p] + momentum_affine @ dpos)
                grid_m[base + offset] += weight * mass
        # Grid update and the walls three cells from the grid's faces.
        for I in ti.grouped(grid_m):
            if grid_m[I] > 0:
                grid_v[I] = grid_v[I] / grid_m[I]
                for a in ti.static(range(d)):
                    if I[a] < bound and grid_v[I][a] < 0:
                        grid_v[I][a] = 0.0
                    if I[a] > nodes - 1 - bound and grid_v[I][a] > 0:
                        grid_v[I][a] = 0.0
        # Grid to particle: velocity, the affine velocity, motion.
        for p in x:
            base = (x[p] * inv_dx - 0.5).cast(int)
            fx = x[p] * inv_dx - base.cast(ti.f64)
            w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]
            new_v = ti.zero(v[p])
            new_c = ti.zero(affine[p])
            for offset in ti.static(ti.grouped(ti.ndrange(*((3,) * d)))):
                dpos = offset.cast(ti.f64) - fx
                g_v = grid_v[base + offset]
                weight = 1.0
                for a in ti.static(range(d)):
                    weight *= w[offset[a]][a]
                new_v += weight * g_v
                new_c += 4.0 * inv_dx * weight * g_v.outer_product(dpos)
            v[p], affine[p] = new_v, new_c
            x[p] += dt * v[p]

    positions = block.positions()
    x.from_numpy(positions)
    v.from_numpy(block.velocities(positions))
    gradient.from_numpy(np.tile(np.eye(d), (n, 1, 1)))
    affine.from_numpy(np.zeros((n, d, d)))
    substep()
    ti.sync()
    started = time.perf_counter()
    for _ in range(steps):
        substep()
    ti.sync()
    seconds = time.perf_counter() - started
    result = summary(x.to_numpy(), v.to_numpy(), mass)
    result.update(code="taichi", particles=n, threads=threads, steps=steps, seconds=seconds)
    result["rate"] = n * steps / seconds
    return result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--particles", type=int, default=100000)
    parser.add_argument("--dimension", type=int, default=2, choices=(2, 3))
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--steps", type=int, default=50)
    args = parser.parse_args()
    block = Block(args.particles, args.dimension)
    print(json.dumps(simulate(block, args.threads, args.steps)))


if __name__ == "__main__":
    main()
