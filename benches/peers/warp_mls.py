"""NVIDIA Warp 1.19 on the CPU (its CPU kernels run on one thread): a line-for-line port of
taichi_mls.py's substep (MLS-MPM, quadratic B-splines, APIC, fixed-corotated elasticity, the
walls three cells in), in f64, on the block of block.py. Run by peers.py:

    python warp_mls.py --particles 100000 --dimension 2 --steps 50

prints one JSON line as taichi_mls.py does (the warm-up step compiles the kernels)."""

import argparse
import json
import time

import numpy as np
import warp as wp

from block import Block, summary

BOUND = 3
# `wp.float64(i + 0)`, not `wp.float64(i)`: Warp 1.19 retypes an unrolled loop's variable to
# float64 after `wp.float64(i)`, and the node index `base + i` then fails to compile.


@wp.func
def spline_weights2(fx: wp.vec2d):
    a = wp.vec2d(wp.float64(1.5), wp.float64(1.5)) - fx
    b = fx - wp.vec2d(wp.float64(1.0), wp.float64(1.0))
    c = fx - wp.vec2d(wp.float64(0.5), wp.float64(0.5))
    half = wp.float64(0.5)
    three_quarters = wp.float64(0.75)
    zero = wp.float64(0.0)
    return wp.mat33d(
        half * a[0] * a[0], three_quarters - b[0] * b[0], half * c[0] * c[0],
        half * a[1] * a[1], three_quarters - b[1] * b[1], half * c[1] * c[1],
        zero, zero, zero,
    )  # fmt: skip


@wp.kernel
def particle_to_grid2(
    x: wp.array(dtype=wp.vec2d),
    v: wp.array(dtype=wp.vec2d),
    affine: wp.array(dtype=wp.mat22d),
    gradient: wp.array(dtype=wp.mat22d),
    grid_v: wp.array2d(dtype=wp.vec2d),
    grid_m: wp.array2d(dtype=wp.float64),
    dt: wp.float64,
    dx: wp.float64,
    inv_dx: wp.float64,
    mass: wp.float64,
    volume: wp.float64,
    mu: wp.float64,
    lam: wp.float64,
):
    p = wp.tid()
    scaled = x[p] * inv_dx
    base = wp.vec2i(int(scaled[0] - wp.float64(0.5)), int(scaled[1] - wp.float64(0.5)))
    fx = scaled - wp.vec2d(wp.float64(base[0]), wp.float64(base[1]))
    w = spline_weights2(fx)
    identity = wp.identity(n=2, dtype=wp.float64)
    f = (identity + dt * affine[p]) * gradient[p]
    gradient[p] = f
    U = wp.mat22d()
    sig = wp.vec2d()
    V = wp.mat22d()
    wp.svd2(f, U, sig, V)
    J = sig[0] * sig[1]
    stress = wp.float64(2.0) * mu * (f - U * wp.transpose(V)) * wp.transpose(f) + identity * (
        lam * J * (J - wp.float64(1.0))
    )
    stress = (-dt * volume * wp.float64(4.0) * inv_dx * inv_dx) * stress
    momentum_affine = stress + mass * affine[p]
    for i in range(3):
        for j in range(3):
            dpos = (wp.vec2d(wp.float64(i + 0), wp.float64(j + 0)) - fx) * dx
            weight = w[0, i] * w[1, j]
            momentum = weight * (mass * v[p] + momentum_affine * dpos)
            node_i = base[0] + i
            node_j = base[1] + j
            wp.atomic_add(grid_v, node_i, node_j, momentum)
            wp.atomic_add(grid_m, node_i, node_j, weight * mass)


@wp.kernel
def grid_update2(grid_v: wp.array2d(dtype=wp.vec2d), grid_m: wp.array2d(dtype=wp.float64), nodes: int):
    i, j = wp.tid()
    m = grid_m[i, j]
    if m > wp.float64(0.0):
        velocity = grid_v[i, j] / m
        index = wp.vec2i(i, j)
        for a in range(2):
            if index[a] < BOUND and velocity[a] < wp.float64(0.0):
                velocity[a] = wp.float64(0.0)
            if index[a] > nodes - 1 - BOUND and velocity[a] > wp.float64(0.0):
                velocity[a] = wp.float64(0.0)
        grid_v[i, j] = velocity


@wp.kernel
def grid_to_particle2(
    x: wp.array(dtype=wp.vec2d),
    v: wp.array(dtype=wp.vec2d),
    affine: wp.array(dtype=wp.mat22d),
    grid_v: wp.array2d(dtype=wp.vec2d),
    dt: wp.float64,
    inv_dx: wp.float64,
):
    p = wp.tid()
    scaled = x[p] * inv_dx
    base = wp.vec2i(int(scaled[0] - wp.float64(0.5)), int(scaled[1] - wp.float64(0.5)))
    fx = scaled - wp.vec2d(wp.float64(base[0]), wp.float64(base[1]))
    w = spline_weights2(fx)
    new_v = wp.vec2d()
    new_c = wp.mat22d()
    for i in range(3):
        for j in range(3):
            dpos = wp.vec2d(wp.float64(i + 0), wp.float64(j + 0)) - fx
            g_v = grid_v[base[0] + i, base[1] + j]
            weight = w[0, i] * w[1, j]
            new_v += weight * g_v
            new_c += wp.float64(4.0) * inv_dx * weight * wp.outer(g_v, dpos)
    v[p] = new_v
    affine[p] = new_c
    x[p] = x[p] + dt * new_v


@wp.func
def spline_weights3(fx: wp.vec3d):
    a = wp.vec3d(wp.float64(1.5), wp.float64(1.5), wp.float64(1.5)) - fx
    b = fx - wp.vec3d(wp.float64(1.0), wp.float64(1.0), wp.float64(1.0))
    c = fx - wp.vec3d(wp.float64(0.5), wp.float64(0.5), wp.float64(0.5))
    half = wp.float64(0.5)
    three_quarters = wp.float64(0.75)
    zero = wp.float64(0.0)
    return wp.mat33d(
        half * a[0] * a[0], three_quarters - b[0] * b[0], half * c[0] * c[0],
        half * a[1] * a[1], three_quarters - b[1] * b[1], half * c[1] * c[1],
        half * a[2] * a[2], three_quarters - b[2] * b[2], half * c[2] * c[2],
    )  # fmt: skip


@wp.kernel
def particle_to_grid3(
    x: wp.array(dtype=wp.vec3d),
    v: wp.array(dtype=wp.vec3d),
    affine: wp.array(dtype=wp.mat33d),
    gradient: wp.array(dtype=wp.mat33d),
    grid_v: wp.array3d(dtype=wp.vec3d),
    grid_m: wp.array3d(dtype=wp.float64),
    dt: wp.float64,
    dx: wp.float64,
    inv_dx: wp.float64,
    mass: wp.float64,
    volume: wp.float64,
    mu: wp.float64,
    lam: wp.float64,
):
    p = wp.tid()
    scaled = x[p] * inv_dx
    base = wp.vec3i(int(scaled[0] - wp.float64(0.5)), int(scaled[1] - wp.float64(0.5)), int(scaled[2] - wp.float64(0.5)))
    fx = scaled - wp.vec3d(wp.float64(base[0]), wp.float64(base[1]), wp.float64(base[2]))
    w = spline_weights3(fx)
    identity = wp.identity(n=3, dtype=wp.float64)
    f = (identity + dt * affine[p]) * gradient[p]
    gradient[p] = f
    U = wp.mat33d()
    sig = wp.vec3d()
    V = wp.mat33d()
    wp.svd3(f, U, sig, V)
    J = sig[0] * sig[1] * sig[2]
    stress = wp.float64(2.0) * mu * (f - U * wp.transpose(V)) * wp.transpose(f) + identity * (
        lam * J * (J - wp.float64(1.0))
    )
    stress = (-dt * volume * wp.float64(4.0) * inv_dx * inv_dx) * stress
    momentum_affine = stress + mass * affine[p]
    for i in range(3):
        for j in range(3):
            for k in range(3):
                dpos = (wp.vec3d(wp.float64(i + 0), wp.float64(j + 0), wp.float64(k + 0)) - fx) * dx
                weight = w[0, i] * w[1, j] * w[2, k]
                wp.atomic_add(
                    grid_v,
                    base[0] + i,
                    base[1] + j,
                    base[2] + k,
                    weight * (mass * v[p] + momentum_affine * dpos),
                )
                wp.atomic_add(grid_m, base[0] + i, base[1] + j, base[2] + k, weight * mass)


@wp.kernel
def grid_update3(grid_v: wp.array3d(dtype=wp.vec3d), grid_m: wp.array3d(dtype=wp.float64), nodes: int):
    i, j, k = wp.tid()
    m = grid_m[i, j, k]
    if m > wp.float64(0.0):
        velocity = grid_v[i, j, k] / m
        index = wp.vec3i(i, j, k)
        for a in range(3):
            if index[a] < BOUND and velocity[a] < wp.float64(0.0):
                velocity[a] = wp.float64(0.0)
            if index[a] > nodes - 1 - BOUND and velocity[a] > wp.float64(0.0):
                velocity[a] = wp.float64(0.0)
        grid_v[i, j, k] = velocity


@wp.kernel
def grid_to_particle3(
    x: wp.array(dtype=wp.vec3d),
    v: wp.array(dtype=wp.vec3d),
    affine: wp.array(dtype=wp.mat33d),
    grid_v: wp.array3d(dtype=wp.vec3d),
    dt: wp.float64,
    inv_dx: wp.float64,
):
    p = wp.tid()
    scaled = x[p] * inv_dx
    base = wp.vec3i(int(scaled[0] - wp.float64(0.5)), int(scaled[1] - wp.float64(0.5)), int(scaled[2] - wp.float64(0.5)))
    fx = scaled - wp.vec3d(wp.float64(base[0]), wp.float64(base[1]), wp.float64(base[2]))
    w = spline_weights3(fx)
    new_v = wp.vec3d()
    new_c = wp.mat33d()
    for i in range(3):
        for j in range(3):
            for k in range(3):
                dpos = wp.vec3d(wp.float64(i + 0), wp.float64(j + 0), wp.float64(k + 0)) - fx
                g_v = grid_v[base[0] + i, base[1] + j, base[2] + k]
                weight = w[0, i] * w[1, j] * w[2, k]
                new_v += weight * g_v
                new_c += wp.float64(4.0) * inv_dx * weight * wp.outer(g_v, dpos)
    v[p] = new_v
    affine[p] = new_c
    x[p] = x[p] + dt * new_v


def simulate(block, steps):
    wp.init()
    d = block.dimension
    n = block.count
    nodes = block.grid_cells + 1
    vector, matrix = (wp.vec2d, wp.mat22d) if d == 2 else (wp.vec3d, wp.mat33d)
    p2g, update, g2p = (
        (particle_to_grid2, grid_update2, grid_to_particle2)
        if d == 2
        else (particle_to_grid3, grid_update3, grid_to_particle3)
    )
    positions = block.positions()
    device = "cpu"
    x = wp.array(positions, dtype=vector, device=device)
    v = wp.array(block.velocities(positions), dtype=vector, device=device)
    affine = wp.zeros(n, dtype=matrix, device=device)
    gradient = wp.array(np.tile(np.eye(d), (n, 1, 1)), dtype=matrix, device=device)
    grid_v = wp.zeros((nodes,) * d, dtype=vector, device=device)
    grid_m = wp.zeros((nodes,) * d, dtype=wp.float64, device=device)
    dx = wp.float64(0.01)
    inv_dx = wp.float64(100.0)
    dt = wp.float64(block.time_step())
    constants = [
        dt,
        dx,
        inv_dx,
        wp.float64(block.particle_mass),
        wp.float64(block.particle_volume),
        wp.float64(block.mu),
        wp.float64(block.lam),
    ]

    def substep():
        grid_v.zero_()
        grid_m.zero_()
        wp.launch(p2g, dim=n, inputs=[x, v, affine, gradient, grid_v, grid_m, *constants], device=device)
        wp.launch(update, dim=(nodes,) * d, inputs=[grid_v, grid_m, nodes], device=device)
        wp.launch(g2p, dim=n, inputs=[x, v, affine, grid_v, dt, inv_dx], device=device)

    substep()
    wp.synchronize()
    started = time.perf_counter()
    for _ in range(steps):
        substep()
    wp.synchronize()
    seconds = time.perf_counter() - started
    result = summary(x.numpy(), v.numpy(), block.particle_mass)
    result.update(code="warp", particles=n, threads=1, steps=steps, seconds=seconds)
    result["rate"] = n * steps / seconds
    return result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--particles", type=int, default=100000)
    parser.add_argument("--dimension", type=int, default=2, choices=(2, 3))
    parser.add_argument("--steps", type=int, default=50)
    args = parser.parse_args()
    wp.config.quiet = True
    block = Block(args.particles, args.dimension)
    print(json.dumps(simulate(block, args.steps)))


if __name__ == "__main__":
    main()
