#!/usr/bin/env python3
"""The serial share of a step, from the call chains of its CPU samples.

For each pipeline, `fractum bench` runs under `perf record -e cpu-clock --call-graph fp` on a
pool of `--threads` threads (2 by default). The bench makes its pool after it has built the
scene, so the first and last samples of the pool's threads in a parallel loop bound the steps
and leave the setup and the teardown out. Each pipeline runs twice, `--steps SHORT LONG`, and
the table counts the long run's samples less the short run's: what the extra steps cost, with
the warm-up step (whose first touch of every buffer page-faults) and the first step's work
cancelled. Within the window each sample is:

- idle, when it falls in the pool's waiting (rayon's spin and sleep, a yield, the scheduler);
- parallel work, when its call chain passes through a parallel loop (rayon's iterator
  splitting, `join`, `scope`);
- serial work otherwise: a system's own body, which runs on one thread while the others wait,
  or the main thread's work outside the pool.

The serial share is serial work over all work: Amdahl's `f`, the share of a step that more
threads cannot divide, and Amdahl's law gives the speedup it allows at 16 threads. The largest
serial sections are named by the innermost Fractum function of their call chains. Unlike the
threads' shares of the samples, this does not move when the machine's other load takes time
from one thread; and unlike the Karp-Flatt fraction of wall times that `fractum bench
--profile` prints, it does not count shared memory bandwidth as serial (a thread waiting on
memory is busy in a parallel loop).

The call chains need frame pointers: build the binary with them, in a target folder of its own,

    RUSTFLAGS="-C force-frame-pointers=yes" CARGO_TARGET_DIR=target/frame-pointers \\
        cargo build --release --bin fractum
    benches/serial_share.py --binary target/frame-pointers/release/fractum \\
        --pipeline bspline-mls linear-usl --particles 1000000 --steps 5 25

Not part of CI or `cargo test`: a measurement, minutes long, on Linux with `perf` (and
`kernel.perf_event_paranoid` at most 1, or root). BENCHMARKS.md ("Every core") records what
it printed.
"""

import argparse
import collections
import os
import re
import subprocess
import sys
import tempfile

# Symbols where a pool thread is waiting for work rather than doing it: rayon's idle loop, the
# yield it spins on, and the kernel's scheduler and futex sleep.
IDLE = re.compile(
    r"rayon_core::sleep|wait_until_cold|wait_until_out_of_work|no_work_found|"
    r"sched_yield|yield_now|__schedule|schedule$|futex|do_syscall_64$|"
    r"entry_SYSCALL|syscall_exit|finish_task_switch|_raw_spin_unlock_irqrestore|"
    r"crossbeam_deque::.*steal|rayon_core::registry::WorkerThread::find_work|"
    r"rayon_core::registry::WorkerThread::take_local_job"
)

# Frames that put a sample inside a parallel loop: rayon's splitting of a parallel iterator,
# `join` and `scope`. A system's own body runs inside the pool too (the step is installed in
# it), but on one thread, with none of these frames above it.
PARALLEL = re.compile(r"bridge_producer_consumer|rayon::iter::plumbing|join_context|rayon_core::scope")


def samples(binary, pipeline, args, steps):
    """Each CPU sample of one `fractum bench` run under perf, as `(time, thread, frames)` with
    the leaf frame first, and the process's id (its main thread's)."""
    with tempfile.TemporaryDirectory() as scratch:
        data = os.path.join(scratch, "perf.data")
        command = [
            "perf", "record", "-q", "-e", "cpu-clock", "-F", str(args.frequency),
            "--call-graph", "fp", "-o", data,
            "--", binary, "bench", "--pipeline", pipeline, "--dimensions", str(args.dimensions),
            "--particles", str(args.particles), "--threads", str(args.threads),
            "--steps", str(steps),
        ]
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        script = subprocess.run(
            ["perf", "script", "-i", data, "-F", "pid,tid,time,ip,sym"],
            check=True, capture_output=True, text=True,
        ).stdout
    found, process = [], None
    for line in script.splitlines():
        if not line.strip():
            continue
        if not line.startswith("\t"):
            # A sample's header (`pid/tid time:`); its frames follow, one per line, indented
            # with a tab.
            fields = line.split()
            process, tid = fields[0].split("/")
            found.append((float(fields[1].rstrip(":")), tid, []))
        elif found:
            frame = line.split(None, 1)
            found[-1][2].append(frame[1] if len(frame) > 1 else "")
    return process, found


def system_of(frames):
    """The innermost Fractum function of a call chain: the system, or the kernel it calls."""
    inner = next((f for f in frames if "fractum_" in f), frames[0] if frames else "?")
    return re.sub(r"\+0x[0-9a-f]+$", "", inner)


def measure(pipeline, args, binary, steps):
    """Work samples of the steps of one run: serial, parallel, outside the pool; idle; and the
    serial samples by Fractum function."""
    main, found = samples(binary, pipeline, args, steps)
    per_thread = collections.Counter(tid for _, tid, _ in found if tid != main)
    pool = [tid for tid, _ in per_thread.most_common(args.threads)]
    times = [
        t for t, tid, frames in found if tid in pool and any(PARALLEL.search(f) for f in frames)
    ]
    if not times:
        sys.exit(f"{pipeline}: no samples in the pool's parallel loops; run more steps")
    # The bench's pool is made after the scene is built: the first and last samples of its
    # threads in a parallel loop bound the steps (the warm-up step included), which leaves the
    # setup and the teardown out.
    first, last = min(times), max(times)
    counts = collections.Counter()
    serial_by = collections.Counter()
    for t, tid, frames in found:
        if not (first <= t <= last and (tid == main or tid in pool)) or not frames:
            continue
        if IDLE.search(frames[0]):
            counts["idle"] += 1
        elif any(PARALLEL.search(f) for f in frames):
            counts["parallel"] += 1
        else:
            counts["outside" if tid == main else "serial"] += 1
            serial_by[system_of(frames)] += 1
    return counts, serial_by


def share(pipeline, args, binary):
    """Prints one row of the table: the samples of the long runs less those of the short ones,
    summed over `--repeat` pairs of runs."""
    counts, serial_by = collections.Counter(), collections.Counter()
    for _ in range(args.repeat):
        short, long = (measure(pipeline, args, binary, steps) for steps in args.steps)
        for total, part in ((counts, 0), (serial_by, 1)):
            total.update(long[part])
            total.subtract(short[part])
    serial_by = collections.Counter({k: n for k, n in serial_by.items() if n > 0})
    work = counts["parallel"] + counts["serial"] + counts["outside"]
    serial = (counts["serial"] + counts["outside"]) / work
    allowed = 1.0 / (serial + (1.0 - serial) / 16.0)
    largest = ", ".join(
        f"{name.replace('fractum_', '')} {100 * n / work:.1f}%"
        for name, n in serial_by.most_common(args.largest)
    )
    cells = [
        pipeline,
        f"{work}",
        f"{100 * serial:.1f}%",
        f"{100 * counts['outside'] / work:.1f}%",
        f"{100 * counts['idle'] / (work + counts['idle']):.1f}%",
        f"{allowed:.1f}",
        largest,
    ]
    print("| " + " | ".join(cells) + " |", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pipeline", nargs="+", required=True)
    parser.add_argument("--particles", type=int, default=1_000_000)
    parser.add_argument("--dimensions", type=int, default=2)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--steps", type=int, nargs=2, default=[5, 25], metavar=("SHORT", "LONG"))
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--largest", type=int, default=3)
    parser.add_argument("--frequency", type=int, default=4999)
    parser.add_argument("--binary", default="target/release/fractum")
    args = parser.parse_args()
    if args.steps[1] <= args.steps[0]:
        sys.exit("--steps: LONG must exceed SHORT")
    header = [
        "pipeline", "work samples", "serial share", "outside the pool", "idle",
        "16 threads (Amdahl)", "largest serial sections",
    ]
    print("| " + " | ".join(header) + " |")
    print("|" + " --- |" * len(header))
    for pipeline in args.pipeline:
        share(pipeline, args, args.binary)


if __name__ == "__main__":
    main()
