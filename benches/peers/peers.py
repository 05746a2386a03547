"""Fractum beside Taichi and Warp on the CPU, on the block `fractum bench` uses (block.py), in
one run: each measurement in a process of its own, the codes interleaved round by round, the
median of the rounds reported. Then the physics check: every code steps the block the same
number of steps of the same size, and the block's mean position and kinetic energy are
compared (the peers with each other to round-off; Fractum, whose pipeline differs from MLS-MPM,
within its discretisation difference).

Run through `benches/peers/run`, which makes the virtual environment and builds `fractum`:

    benches/peers/run --particles 100000 --dimensions 2 --threads 1 2

BENCHMARKS.md ("Beside Taichi and Warp") has the figures and the machine they were taken on."""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from block import Block, summary
from frames import read_particles

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]


def fractum_binary():
    return os.environ.get("FRACTUM_BIN", str(REPO / "target" / "release" / "fractum"))


def fractum_rate(pipeline, particles, dimension, threads, steps):
    """`fractum bench` for one case: (particle count, particle-steps per second)."""
    out = subprocess.run(
        [
            fractum_binary(), "bench", "--pipeline", pipeline, "--dimensions", str(dimension),
            "--particles", str(particles), "--threads", str(threads), "--steps", str(steps),
        ],
        check=True, capture_output=True, text=True,
    ).stdout  # fmt: skip
    for line in out.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 7 and cells[1] == f"{dimension}D":
            return int(cells[2]), float(cells[6])
    raise RuntimeError(f"no result in fractum bench's output:\n{out}")


def peer(script, particles, dimension, threads, steps):
    """One run of a peer's script: its JSON line."""
    command = [sys.executable, str(HERE / script), "--particles", str(particles)]
    command += ["--dimension", str(dimension), "--steps", str(steps)]
    if script.startswith("taichi"):
        command += ["--threads", str(threads)]
    out = subprocess.run(command, check=True, capture_output=True, text=True, cwd=HERE).stdout
    return json.loads(out.strip().splitlines()[-1])


def cases(args):
    """(label, code, threads, measure) for each code and thread count, in the interleaved order
    of one round; Warp's CPU kernels run on one thread, so it has one case."""
    out = []
    for threads in args.threads:
        for pipeline in args.pipeline:
            out.append((f"fractum {pipeline}", threads, "fractum", pipeline))
        out.append(("taichi mpm99 (MLS)", threads, "taichi", None))
        if threads == 1:
            out.append(("warp (MLS)", 1, "warp", None))
    return out


def measure_rates(args, dimension, steps):
    rates = {}
    for round_ in range(args.rounds):
        for label, threads, code, pipeline in cases(args):
            if code == "fractum":
                _, rate = fractum_rate(pipeline, args.particles, dimension, threads, steps)
            else:
                script = "taichi_mls.py" if code == "taichi" else "warp_mls.py"
                rate = peer(script, args.particles, dimension, threads, steps)["rate"]
            rates.setdefault((label, threads), []).append(rate)
            print(f"  round {round_ + 1}: {label}, {threads} thread(s): {rate:.3e}", flush=True)
    return {key: statistics.median(values) for key, values in rates.items()}


def fractum_scene(block, pipeline_systems, steps):
    """The block as a RON scene stepping `steps` steps of the peers' fixed size, with one frame
    at the end."""
    d = block.dimension
    point = lambda value: "(" + ", ".join([repr(value)] * d) + ")"  # noqa: E731
    shape = "Rectangle" if d == 2 else "Box"
    amplitude = "(" + ", ".join(repr(a) for a in (0.1, 0.05, 0.025)[:d]) + ")"
    top = block.grid_cells * 0.01
    systems = ",\n        ".join(pipeline_systems)
    return f"""(
    title: "the peers' benchmark block",
    units: SI,
    time: (step: Fixed({block.time_step()!r}), end: Steps({steps})),
    grid: (min: {point(0.0)}, max: {point(top)}, spacing: 0.01),
    materials: {{ "elastic": (density: 1000.0, youngs_modulus: 1.0e6, poisson_ratio: 0.3) }},
    bodies: [(
        name: "block",
        shape: {shape}(min: {point(block.margin)}, max: {point(block.margin + block.side)}),
        material: "elastic",
        particles_per_cell: 2,
        velocity: Sine(amplitude: {amplitude}, axis: X, wavelength: {2 * block.side!r}, origin: {block.margin!r}),
    )],
    output: (vtu_every: {steps}, csv_every: 0),
    pipeline: [
        {systems},
    ],
)
"""


# The `fractum bench` pipelines the check runs (tools/src/bench.rs), as scene entries.
CHECKED_PIPELINES = {
    "bspline-usl": [
        '(system: "basis/bspline")',
        '(system: "predictor/usl")',
        '(system: "stress/linear_elastic")',
        '(system: "advection/usl")',
    ],
    "bspline-apic": [
        '(system: "basis/bspline")',
        '(system: "predictor/usl")',
        '(system: "stress/linear_elastic")',
        '(system: "advection/usl", params: (transfer: Apic))',
    ],
    "bspline-mls": [
        '(system: "basis/mls")',
        '(system: "predictor/mls")',
        '(system: "stress/linear_elastic")',
        '(system: "advection/mls")',
    ],
    "gimp-usl": [
        '(system: "basis/gimp")',
        '(system: "predictor/usl")',
        '(system: "stress/linear_elastic")',
        '(system: "advection/usl")',
    ],
    "linear-usl": [
        '(system: "basis/linear")',
        '(system: "predictor/usl")',
        '(system: "stress/linear_elastic")',
        '(system: "advection/usl")',
    ],
}


def fractum_state(block, pipeline, steps):
    with tempfile.TemporaryDirectory() as folder:
        scene = Path(folder) / "block.ron"
        scene.write_text(fractum_scene(block, CHECKED_PIPELINES[pipeline], steps))
        out = Path(folder) / "out"
        subprocess.run(
            [fractum_binary(), "run", str(scene), "--out", str(out), "--quiet", "--threads", "2"],
            check=True,
            capture_output=True,
        )
        frames = sorted((out / "frames").glob("particles_*.vtu"))
        arrays = read_particles(frames[-1])
    return summary(arrays["position"][:, : block.dimension], arrays["velocity"][:, : block.dimension], block.particle_mass)


def physics_check(args, dimension, steps):
    """Each code's mean position and kinetic energy after `steps` steps (one warm-up step and
    `steps − 1` timed ones for the peers)."""
    block = Block(args.particles, dimension)
    states = {
        "taichi": peer("taichi_mls.py", args.particles, dimension, 1, steps - 1),
        "warp": peer("warp_mls.py", args.particles, dimension, 1, steps - 1),
    }
    for pipeline in args.pipeline:
        if pipeline in CHECKED_PIPELINES:
            states[f"fractum {pipeline}"] = fractum_state(block, pipeline, steps)
    start = summary(block.positions(), block.velocities(block.positions()), block.particle_mass)
    return start, states


def report(args, dimension, rates, start, states, steps):
    particles = Block(args.particles, dimension).count
    print(f"\n{dimension}D, {particles} particles, f64, particle-steps per second (median of {args.rounds}):\n")
    print("| code | " + " | ".join(f"{t} thread{'s' if t > 1 else ''}" for t in args.threads) + " |")
    print("| --- |" + " --- |" * len(args.threads))
    labels = dict.fromkeys(label for label, *_ in cases(args))
    for label in labels:
        row = [f"{rates[(label, t)]:.3g}" if (label, t) in rates else "–" for t in args.threads]
        print(f"| {label} | " + " | ".join(row) + " |")
    print(f"\nAfter {steps} steps of {Block(args.particles, dimension).time_step():.4g} s:\n")
    print("| code | mean position (m) | kinetic energy (J) |")
    print("| --- | --- | --- |")
    for name, state in [("start", start), *states.items()]:
        position = ", ".join(f"{x:.12f}" for x in state["mean_position"])
        print(f"| {name} | ({position}) | {state['kinetic_energy']:.6e} |")
    peers = [np.array(states[k]["mean_position"]) for k in ("taichi", "warp")]
    print(f"\ntaichi − warp mean position: {np.abs(peers[0] - peers[1]).max():.3e} m")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--particles", type=int, default=100000)
    parser.add_argument("--dimensions", type=int, nargs="+", default=[2], choices=(2, 3))
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--pipeline", nargs="+", default=["bspline-mls", "bspline-usl"])
    parser.add_argument("--steps", type=int, default=None, help="timed steps (default: about 5 million particle-steps)")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--check-steps", type=int, default=200)
    args = parser.parse_args()
    steps = args.steps or max(5, round(5.0e6 / args.particles))
    for dimension in args.dimensions:
        print(f"{dimension}D: {args.rounds} rounds of {steps} timed steps", flush=True)
        rates = measure_rates(args, dimension, steps)
        start, states = physics_check(args, dimension, args.check_steps)
        report(args, dimension, rates, start, states, args.check_steps)


if __name__ == "__main__":
    main()
