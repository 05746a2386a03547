"""Reading Fractum's VTU particle frames with the standard library: the arrays of one frame
(zlib-compressed, base64-encoded, UInt64 headers, as `fractum run` writes them) and the frames a
run's particles.pvd lists."""
import base64
import re
import struct
import zlib
from array import array

TYPES = {"Float64": "d", "Int32": "i", "Int64": "q", "UInt8": "B"}


def decode(kind, text):
    """One zlib-compressed, base64-encoded VTK data array (UInt64 headers)."""
    blocks = struct.unpack("<Q", base64.b64decode(text[:12])[:8])[0]
    header_chars = ((24 + 8 * blocks + 2) // 3) * 4
    header = struct.unpack("<%dQ" % (3 + blocks), base64.b64decode(text[:header_chars]))
    raw = base64.b64decode(text[header_chars:])
    values, offset = array(TYPES[kind]), 0
    for size in header[3:]:
        values.frombytes(zlib.decompress(raw[offset:offset + size]))
        offset += size
    return values


def read_frame(path, wanted):
    """The arrays named in `wanted` ("Points" for the positions) of one VTU frame."""
    text = open(path).read()
    arrays = {}
    for match in re.finditer(r"<DataArray ([^>]*)>([^<]*)</DataArray>", text):
        attributes = dict(re.findall(r'(\w+)="([^"]*)"', match.group(1)))
        name = attributes.get("Name", "Points")
        if name in wanted:
            arrays[name] = decode(attributes["type"], match.group(2).strip())
    return arrays


def frames(run):
    """(time, path) of each frame the run's particles.pvd lists."""
    pvd = open(run + "/particles.pvd").read()
    found = re.findall(r'timestep="([^"]+)"[^>]*file="([^"]+)"', pvd)
    return [(float(t), run + "/" + f) for t, f in found]
