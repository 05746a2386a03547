#!/usr/bin/env python3
"""Digitises the experiments' traced cracks of the semicircular bending (SCB) tests.

The first paper's repository (github.com/migmolper/Fracture-MPM-Eigensoftening) holds, for each
notch angle, an Inkscape drawing of the cracks of Lim et al.'s specimens traced by hand:
`Figure-Angle-Forces-pattern-{0,30,60}.svg`. Each drawing has one thick stroke, the notch, and
one thin path per traced crack. The drawings have no axes, so this script places them in the
scenes' frame (metres in the scenes, millimetres here): the notch's mouth at the origin (the
centre of the flat edge), y up, and the scale that makes the drawn notch 16.6 mm long, the
notch of scenes/scb_*.ron. It writes the traces as `scb_<angle>_traces.csv` beside itself
(columns line, x, y, in metres: the overlay `fractum snapshot --overlay` and the verification
pages draw over a frame) and prints, for the heights the verification cases measure, where
each trace crosses the line y = height, the traces' mean, their largest distance from it, and
the tolerance the catalogue holds the simulated crack to: that distance widened by one cell of
the scenes' grid (1.5 mm), for the hand tracing and for where a failed band's centre can lie on
a lattice of particles.

It also prints how well the drawing's own proportions hold: the drawn notch's angle against
the nominal one, and where the traces end against where the loader stands (x = 0, y = 47.5 mm).
The drawings are not rotated to make the notch's angle nominal: the traces' upper ends lie
within 3 mm of x = 0 as drawn, and a rotation by the notch's error (4.4° at 30°, 2.1° at 60°)
would move them 2-4 mm off the loader.

Usage: python3 scb_traces.py PATH   (PATH: a checkout of the repository above, or a folder
holding the three SVG files). Only the standard library is needed.
"""

import csv
import math
import os
import re
import sys

NOTCH_LENGTH_MM = 16.6
RADIUS_MM = 47.5
CELL_MM = 1.5
ANGLES = (0, 30, 60)
HEIGHTS_MM = (20.0, 30.0, 40.0)
THICK_STROKE = 2.0

NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def path_points(d):
    """The end points of every segment of an SVG path's `d` (control points dropped: the
    traces' segments are a few tenths of a unit long)."""
    tokens = re.findall(r"[MmLlHhVvCcSsQqZz]|" + NUMBER, d)
    points, index, command = [], 0, None
    x = y = 0.0
    start = None
    arity = {"M": 2, "L": 2, "H": 1, "V": 1, "C": 6, "S": 4, "Q": 4}
    while index < len(tokens):
        if tokens[index].isalpha():
            command = tokens[index]
            index += 1
            if command in "Zz":
                x, y = start
                points.append((x, y))
                continue
        upper = command.upper()
        values = [float(v) for v in tokens[index:index + arity[upper]]]
        index += arity[upper]
        relative = command.islower()
        if upper == "H":
            x = x + values[0] if relative else values[0]
        elif upper == "V":
            y = y + values[0] if relative else values[0]
        else:
            dx, dy = values[-2], values[-1]
            x, y = (x + dx, y + dy) if relative else (dx, dy)
        points.append((x, y))
        if upper == "M":
            start = (x, y)
            command = "l" if relative else "L"
    return points


def strokes(svg_text):
    """(stroke width, points) of every path of the drawing."""
    found = []
    for match in re.finditer(r"<path(.*?)/>", svg_text, re.S):
        body = match.group(1)
        width = float(re.search(r"stroke-width:(" + NUMBER + ")", body).group(1))
        d = re.search(r'\sd="([^"]*)"', body).group(1)
        found.append((width, path_points(d)))
    return found


def in_millimetres(svg_text):
    """The notch and the traces in the scenes' frame (mm), and the drawing's scale."""
    paths = strokes(svg_text)
    notches = [points for width, points in paths if width > THICK_STROKE]
    if len(notches) != 1:
        raise SystemExit(f"expected one thick stroke (the notch), found {len(notches)}")
    (mouth_x, mouth_y), (tip_x, tip_y) = notches[0][0], notches[0][-1]
    units_per_mm = math.hypot(tip_x - mouth_x, tip_y - mouth_y) / NOTCH_LENGTH_MM

    def place(point):
        return ((point[0] - mouth_x) / units_per_mm, (mouth_y - point[1]) / units_per_mm)

    traces = [[place(p) for p in points] for width, points in paths if width <= THICK_STROKE]
    return place((tip_x, tip_y)), traces, units_per_mm


def crossing(trace, height):
    """Where a trace crosses y = height: the mean of its crossings when it wiggles across."""
    found = []
    for (x0, y0), (x1, y1) in zip(trace, trace[1:]):
        if (y0 - height) * (y1 - height) < 0.0:
            found.append(x0 + (height - y0) / (y1 - y0) * (x1 - x0))
    return sum(found) / len(found) if found else None


def main():
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    here = os.path.dirname(os.path.abspath(__file__))
    for angle in ANGLES:
        name = f"Figure-Angle-Forces-pattern-{angle}.svg"
        with open(os.path.join(sys.argv[1], name), encoding="utf-8") as svg:
            tip, traces, units_per_mm = in_millimetres(svg.read())
        drawn = math.degrees(math.atan2(tip[0], tip[1]))
        top = max(y for trace in traces for _, y in trace)
        ends = ", ".join(f"{max(trace, key=lambda p: p[1])[0]:.1f}" for trace in traces)
        print(f"{angle}°: {len(traces)} traces, {units_per_mm:.3f} units/mm; notch drawn at "
              f"{drawn:.1f}° (nominal {angle}°); traces reach y = {top:.1f} mm at x = {ends} mm "
              f"(the loader stands at x = 0, y = {RADIUS_MM} mm)")
        with open(os.path.join(here, f"scb_{angle}_traces.csv"), "w", newline="") as out:
            rows = csv.writer(out)
            rows.writerow(["line", "x", "y"])
            for number, trace in enumerate(traces):
                for x, y in trace:
                    rows.writerow([number, f"{x * 1.0e-3:.6e}", f"{y * 1.0e-3:.6e}"])
        for height in HEIGHTS_MM:
            xs = [x for x in (crossing(t, height) for t in traces) if x is not None]
            mean = sum(xs) / len(xs)
            spread = max(abs(x - mean) for x in xs)
            tolerance = math.ceil((spread + CELL_MM) * 10.0) / 10.0
            listed = ", ".join(f"{x:.2f}" for x in xs)
            print(f"  y = {height:.0f} mm: x = {listed} mm; mean {mean:.2f}, largest distance "
                  f"from it {spread:.2f}, tolerance {tolerance:.1f} mm")


if __name__ == "__main__":
    main()
