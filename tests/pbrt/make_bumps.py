#!/usr/bin/env python3
"""Writes `scenes/bumps.png` (a 16×16 height field, 8-bit grey, read with `encoding "linear"`)
and `scenes/displacement.pbrt`: pbrt-v4's `displacement` (bump mapping) on a plane without
vertex normals and on a half cylinder with them, lit by a low distant light.

    python3 tests/pbrt/make_bumps.py
"""

from __future__ import annotations

import math
import struct
import zlib
from pathlib import Path

SCENES = Path(__file__).resolve().parent / "scenes"


def png_grey(path: Path, rows: list[list[int]]) -> None:
    """An 8-bit grey PNG written by hand (zlib and struct only)."""
    h, w = len(rows), len(rows[0])
    raw = b"".join(b"\x00" + bytes(r) for r in rows)

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def heights() -> list[list[int]]:
    """Smooth bumps: a sine along u (two periods) times a gentler one along v."""
    rows = []
    for y in range(16):
        row = []
        for x in range(16):
            h = 0.5 + 0.3 * math.sin(2 * math.pi * x / 8) * (0.6 + 0.4 * math.cos(2 * math.pi * y / 16))
            row.append(round(255 * h))
        rows.append(row)
    return rows


def half_cylinder(n: int = 24) -> str:
    """A half cylinder of radius 0.6 along X, with vertex normals and texture coordinates."""
    p, nrm, uv, idx = [], [], [], []
    for i in range(n + 1):
        a = math.pi * i / n
        y, z = 0.6 * math.sin(a), 0.6 * math.cos(a)
        for x in (-1.0, 1.0):
            p += [x, y, z + 0.2]
            nrm += [0.0, math.sin(a), math.cos(a)]
            uv += [(x + 1) / 2, i / n]
    for i in range(n):
        a, b = 2 * i, 2 * i + 2
        idx += [a, a + 1, b + 1, a, b + 1, b]
    fmt = " ".join
    return (
        f'  Shape "trianglemesh" "point3 P" [ {fmt(f"{v:.6g}" for v in p)} ]\n'
        f'    "normal N" [ {fmt(f"{v:.6g}" for v in nrm)} ]\n'
        f'    "point2 uv" [ {fmt(f"{v:.6g}" for v in uv)} ]\n'
        f'    "integer indices" [ {fmt(str(v) for v in idx)} ]\n'
    )


SCENE = """# A test scene of the pbrt-v4 reader (see tests/pbrt/README.md), written by
# tests/pbrt/make_bumps.py: pbrt-v4's displacement (bump mapping) by a float image texture.
LookAt 0 2.2 3.4  0 0.3 0  0 1 0
Camera "perspective" "float fov" [ 40 ]
Film "rgb" "integer xresolution" [ 96 ] "integer yresolution" [ 64 ] "string filename" [ "out.exr" ]
Sampler "independent" "integer pixelsamples" [ 64 ]
Integrator "path" "integer maxdepth" [ 5 ]
PixelFilter "box" "float xradius" [ 0.5 ] "float yradius" [ 0.5 ]
WorldBegin
LightSource "distant" "point3 from" [ -3 1.2 1 ] "point3 to" [ 0 0 0 ] "rgb L" [ 3 2.8 2.6 ]
LightSource "infinite" "rgb L" [ 0.15 0.17 0.2 ]
Texture "bumps" "float" "imagemap" "string filename" [ "bumps.png" ] "string encoding" "linear"
  "string filter" "bilinear" "float scale" [ 0.15 ]
AttributeBegin
  Material "diffuse" "rgb reflectance" [ 0.7 0.65 0.6 ] "texture displacement" "bumps"
  Shape "trianglemesh" "point3 P" [ -2.5 0 -2  2.5 0 -2  2.5 0 2  -2.5 0 2 ]
    "point2 uv" [ 0 0  2 0  2 2  0 2 ] "integer indices" [ 0 2 1  0 3 2 ]
AttributeEnd
AttributeBegin
  Material "coateddiffuse" "rgb reflectance" [ 0.3 0.5 0.7 ] "float roughness" [ 0.1 ]
    "texture displacement" "bumps"
{cylinder}AttributeEnd
"""


def main() -> None:
    png_grey(SCENES / "bumps.png", heights())
    (SCENES / "displacement.pbrt").write_text(SCENE.replace("{cylinder}", half_cylinder()))


if __name__ == "__main__":
    main()
