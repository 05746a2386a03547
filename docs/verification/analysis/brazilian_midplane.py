#!/usr/bin/env python3
"""What drives the Brazilian disk's halves apart after the split: for each frame of a run of
`scenes/brazilian_dfg.ron` (or a refinement of it), the x momentum of the disk's right half
(every particle of body 0 with x > 0, failed or not), its rate of change between frames, and
the push the material at the mid-plane exerts across x = 0:

    F = -(1 / 2w) * sum over disk particles with |x| < w of sigma_xx * V,

the particles' stress integrated over the plane (V includes the thickness), with w two particle
spacings. Where F matches d(p_right)/dt, the mid-plane material (the failed crack band) is what
accelerates the halves; what is left is the platens' and walls' share. Also printed: the part of
F from the band's particles with |y| > y0 (the zones under the platens, y0 = 2 mm), with their
volume-weighted mean sigma_xx and sigma_yy and the fraction of their volume failed (damage at
least 0.5).

Standard library only. Usage: brazilian_midplane.py RUN_DIR [--from 8e-6] [--every 3] [--y0 2e-3]
"""
import argparse
import sys

from vtu_frames import frames, read_frame

def measure(path, thickness, y0):
    """Right half's x momentum and mass, the mid-plane push, and the share and state of the
    band's particles beyond |y| = y0, of one frame."""
    a = read_frame(path, {"body", "mass", "velocity", "Points", "stress", "volume", "damage"})
    disk = [i for i, b in enumerate(a["body"]) if b == 0]
    spacing = (a["volume"][disk[0]] / thickness) ** 0.5
    w = 2.0 * spacing
    momentum, mass, push = 0.0, 0.0, 0.0
    outer = {"push": 0.0, "volume": 0.0, "sxx": 0.0, "syy": 0.0, "failed": 0.0}
    for i in disk:
        x, v = a["Points"][3 * i], a["volume"][i]
        if x > 0.0:
            momentum += a["mass"][i] * a["velocity"][3 * i]
            mass += a["mass"][i]
        if abs(x) < w:
            share = -a["stress"][9 * i] * v / (2.0 * w)
            push += share
            if abs(a["Points"][3 * i + 1]) > y0:
                outer["push"] += share
                outer["volume"] += v
                outer["sxx"] += a["stress"][9 * i] * v
                outer["syy"] += a["stress"][9 * i + 4] * v
                outer["failed"] += v if a["damage"][i] >= 0.5 else 0.0
    for key in ("sxx", "syy", "failed"):
        outer[key] /= outer["volume"]
    return momentum, mass, push, outer


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run")
    parser.add_argument("--from", dest="start", type=float, default=8e-6)
    parser.add_argument("--every", type=int, default=3, help="use every k-th frame")
    parser.add_argument("--thickness", type=float, default=2.0e-3)
    parser.add_argument("--y0", type=float, default=2.0e-3, help="|y| beyond which (m)")
    args = parser.parse_args()
    print(
        "time (µs) | push across x = 0 (N) | d(p_right)/dt (N) | right half's v_x (m/s) | "
        "beyond |y| = y0: push (N), sigma_xx, sigma_yy (MPa), failed"
    )
    previous = None
    for k, (t, path) in enumerate(frames(args.run)):
        if t < args.start or k % args.every:
            continue
        momentum, mass, push, outer = measure(path, args.thickness, args.y0)
        rate = (momentum - previous[1]) / (t - previous[0]) if previous else float("nan")
        previous = (t, momentum)
        print(
            "%9.2f | %21.0f | %17.0f | %22.1f | %6.0f %6.0f %6.0f %5.2f"
            % (
                t * 1e6,
                push,
                rate,
                momentum / mass,
                outer["push"],
                outer["sxx"] / 1e6,
                outer["syy"] / 1e6,
                outer["failed"],
            )
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
