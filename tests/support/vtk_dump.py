"""Reads VTU frames with VTK's own XML reader and dumps what it read, for tests/vtk_reader.rs.

Usage: python3 vtk_dump.py OUT FRAME...

For each FRAME, writes OUT/<frame stem>/<array>.f64: the array's values as little-endian
float64 (integers are exact in float64), points as `points.f64`, and `cells.txt` with the
number of cells and the VTK cell type of each distinct type. A file VTK cannot read exits
non-zero with its error.
"""

import os
import sys

import vtk
from vtk.util.numpy_support import vtk_to_numpy


def dump(frame, out):
    reader = vtk.vtkXMLUnstructuredGridReader()
    errors = vtk.vtkStringOutputWindow()
    vtk.vtkOutputWindow.SetInstance(errors)
    reader.SetFileName(frame)
    reader.Update()
    if reader.GetErrorCode() != 0 or "ERROR" in errors.GetOutput():
        sys.exit(f"{frame}: VTK could not read it: {errors.GetOutput()}")
    grid = reader.GetOutput()
    os.makedirs(out, exist_ok=True)
    points = grid.GetPoints()
    if points is not None:
        vtk_to_numpy(points.GetData()).astype("<f8").tofile(os.path.join(out, "points.f64"))
    data = grid.GetPointData()
    for i in range(data.GetNumberOfArrays()):
        array = data.GetArray(i)
        values = vtk_to_numpy(array).astype("<f8")
        values.tofile(os.path.join(out, f"{array.GetName()}.f64"))
    types = sorted({grid.GetCellType(c) for c in range(grid.GetNumberOfCells())})
    with open(os.path.join(out, "cells.txt"), "w") as f:
        f.write(f"{grid.GetNumberOfPoints()} {grid.GetNumberOfCells()} {' '.join(map(str, types))}\n")


def main():
    out = sys.argv[1]
    for frame in sys.argv[2:]:
        stem = os.path.splitext(os.path.basename(frame))[0]
        dump(frame, os.path.join(out, stem))
    print(f"VTK {vtk.vtkVersion.GetVTKVersion()} read {len(sys.argv) - 2} frames")


if __name__ == "__main__":
    main()
