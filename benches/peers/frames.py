"""Reads the positions and point arrays of a Fractum particle frame (VTU, inline binary, zlib
compressed with a UInt64 header, as engine/io writes them) with the standard library and numpy,
so that the peers' environment needs no VTK."""

import base64
import math
import xml.etree.ElementTree as ET
import zlib

import numpy as np

TYPES = {"Float64": np.float64, "Float32": np.float32, "Int32": np.int32, "UInt32": np.uint32,
         "UInt16": np.uint16, "UInt8": np.uint8, "Int64": np.int64, "UInt64": np.uint64}  # fmt: skip


def _decode(element):
    text = "".join(element.text.split())
    # The header (block count, block size, last block's size, each block's compressed size)
    # and the blocks are two base64 strings one after the other.
    blocks = int(np.frombuffer(base64.b64decode(text[:32]), dtype="<u8")[0])
    header_chars = 4 * math.ceil(8 * (3 + blocks) / 3)
    header = np.frombuffer(base64.b64decode(text[:header_chars]), dtype="<u8")
    data = base64.b64decode(text[header_chars:])
    raw, at = [], 0
    for size in header[3 : 3 + blocks]:
        raw.append(zlib.decompress(data[at : at + int(size)]))
        at += int(size)
    values = np.frombuffer(b"".join(raw), dtype=TYPES[element.get("type")])
    components = int(element.get("NumberOfComponents", "1"))
    return values.reshape(-1, components) if components > 1 else values


def read_particles(path):
    """`position` and every point array of the frame at `path`, by name."""
    if ET.parse(path).getroot().get("compressor") != "vtkZLibDataCompressor":
        raise ValueError(f"{path}: expected a zlib-compressed frame")
    piece = ET.parse(path).getroot().find("UnstructuredGrid/Piece")
    arrays = {"position": _decode(piece.find("Points/DataArray"))}
    for element in piece.find("PointData"):
        arrays[element.get("Name")] = _decode(element)
    return arrays
