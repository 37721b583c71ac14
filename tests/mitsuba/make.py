#!/usr/bin/env python3
"""Writes the Mitsuba test scenes and their assets (`scenes/`), and with `--refs` renders each
scene with Mitsuba 3 itself into `refs/NAME.exr` (`../../../shared/tools/mitsuba_xml.py`,
llvm_ad_rgb, independent sampler, the spp given, seed 0).

    python3 tests/mitsuba/make.py [--refs [--spp 16384] [--only NAME ...]]
"""

import argparse
import os
import struct
import subprocess
import sys
import zlib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.join(HERE, "scenes")
REFS = os.path.join(HERE, "refs")


def write(name: str, text: str) -> None:
    with open(os.path.join(SCENES, name), "w") as f:
        f.write(text)


def png(name: str, rgb: np.ndarray) -> None:
    """An 8-bit RGB PNG written by hand (zlib and struct only)."""
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].astype(np.uint8).tobytes() for y in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    data = b"\x89PNG\r\n\x1a\n" + chunk(
        b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    )
    data += chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
    with open(os.path.join(SCENES, name), "wb") as f:
        f.write(data)


def pfm_sky() -> np.ndarray:
    """A 64×32 latitude-longitude sky: a blue gradient, a warm sun and a green ground."""
    h, w = 32, 64
    y = (np.arange(h) + 0.5) / h
    x = (np.arange(w) + 0.5) / w
    theta = y[:, None] * np.pi
    phi = x[None, :] * 2 * np.pi
    sky = np.zeros((h, w, 3), np.float32)
    up = np.cos(theta)
    sky[..., 0] = 0.3 + 0.3 * up
    sky[..., 1] = 0.4 + 0.3 * up
    sky[..., 2] = 0.6 + 0.4 * up
    ground = theta > np.pi / 2
    sky[np.broadcast_to(ground, (h, w))] = [0.15, 0.25, 0.1]
    sun = np.exp(-(((phi - 1.2) ** 2) + (theta - 0.7) ** 2) / 0.02)
    sky += (sun[..., None] * np.array([20.0, 15.0, 8.0])).astype(np.float32)
    return sky


def exr(name: str, img: np.ndarray) -> None:
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    mi.Bitmap(img.astype(np.float32)).write(os.path.join(SCENES, name))


def exr_with_chromaticities(name: str, img: np.ndarray, chroma: tuple) -> None:
    """An uncompressed scanline float EXR with a `chromaticities` attribute (red, green, blue
    and white x, y), written by hand (struct only): Mitsuba's own writer has no way to set it.
    """
    h, w, _ = img.shape

    def attr(name: str, kind: str, data: bytes) -> bytes:
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(data)) + data

    channels = b"".join(c + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in (b"B", b"G", b"R")) + b"\0"
    header = (
        attr("channels", "chlist", channels)
        + attr("chromaticities", "chromaticities", struct.pack("<8f", *chroma))
        + attr("compression", "compression", b"\0")
        + attr("dataWindow", "box2i", struct.pack("<4i", 0, 0, w - 1, h - 1))
        + attr("displayWindow", "box2i", struct.pack("<4i", 0, 0, w - 1, h - 1))
        + attr("lineOrder", "lineOrder", b"\0")
        + attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
        + attr("screenWindowCenter", "v2f", struct.pack("<2f", 0.0, 0.0))
        + attr("screenWindowWidth", "float", struct.pack("<f", 1.0))
        + b"\0"
    )
    start = 8 + len(header) + 8 * h
    line = 8 + 3 * 4 * w
    out = struct.pack("<ii", 20000630, 2) + header
    out += b"".join(struct.pack("<Q", start + y * line) for y in range(h))
    for y in range(h):
        data = b"".join(img[y, :, c].astype("<f4").tobytes() for c in (2, 1, 0))
        out += struct.pack("<ii", y, len(data)) + data
    with open(os.path.join(SCENES, name), "wb") as f:
        f.write(out)


# Adobe RGB (1998): a wide gamut with the D65 white point.
ADOBE_RGB = (0.64, 0.33, 0.21, 0.71, 0.15, 0.06, 0.3127, 0.329)


def serialized(name: str, meshes: list) -> None:
    """Mitsuba's serialized format, version 4, single precision."""
    out = b""
    offsets = []
    for pos, tris, uvs in meshes:
        offsets.append(len(out))
        flags = 0x1000 | (0x2 if uvs is not None else 0)
        body = (
            struct.pack("<I", flags)
            + b"mesh\x00"
            + struct.pack("<QQ", len(pos), len(tris))
        )
        body += np.asarray(pos, "<f4").tobytes()
        if uvs is not None:
            body += np.asarray(uvs, "<f4").tobytes()
        body += np.asarray(tris, "<u4").tobytes()
        out += struct.pack("<HH", 0x041C, 4) + zlib.compress(body)
    out += b"".join(struct.pack("<Q", o) for o in offsets) + struct.pack(
        "<I", len(meshes)
    )
    with open(os.path.join(SCENES, name), "wb") as f:
        f.write(out)


def assets() -> None:
    checks = np.zeros((8, 8, 3), np.uint8)
    for y in range(8):
        for x in range(8):
            checks[y, x] = [40 + 200 * ((x + y) % 2), 30 + 25 * x, 30 + 25 * y]
    png("checks.png", checks)
    # A bumpy normal map (tangent space, 8-bit): rows of ridges along u.
    n = np.zeros((16, 16, 3))
    for x in range(16):
        s = 0.6 * np.sin(2 * np.pi * x / 8)
        v = np.array([s, 0.0, 1.0])
        n[:, x] = v / np.linalg.norm(v)
    png("ridges.png", np.round((n * 0.5 + 0.5) * 255))
    # A height field for bump mapping: bumps in u and v.
    y, x = np.mgrid[0:16, 0:16]
    h = 0.5 + 0.25 * np.sin(2 * np.pi * x / 8) + 0.2 * np.cos(2 * np.pi * y / 16)
    png("bumps.png", np.repeat(np.round(h * 255)[..., None], 3, axis=2))
    exr("sky.exr", pfm_sky())
    # The same sky's numbers stored as Adobe RGB: readers must convert them to Rec. 709.
    exr_with_chromaticities("sky_adobe.exr", pfm_sky(), ADOBE_RGB)
    with open(os.path.join(SCENES, "octa.obj"), "w") as f:
        f.write("# an octahedron with texture coordinates and no normals\n")
        f.writelines(
            "v {:g} {:g} {:g}\n".format(*p)
            for p in [
                (1, 0, 0),
                (-1, 0, 0),
                (0, 1, 0),
                (0, -1, 0),
                (0, 0, 1),
                (0, 0, -1),
            ]
        )
        f.writelines(
            "vt {:g} {:g}\n".format(*t) for t in [(0, 0), (1, 0), (1, 1), (0, 1)]
        )
        for a, b, c in [
            (1, 3, 5),
            (3, 2, 5),
            (2, 4, 5),
            (4, 1, 5),
            (3, 1, 6),
            (2, 3, 6),
            (4, 2, 6),
            (1, 4, 6),
        ]:
            f.write(f"f {a}/1 {b}/2 {c}/3\n")
    with open(os.path.join(SCENES, "quad_uv2.obj"), "w") as f:
        f.write("# a unit quad facing +z, texture coordinates from -0.5 to 1.5\n")
        f.write("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n")
        f.write("vt -0.5 -0.5\nvt 1.5 -0.5\nvt 1.5 1.5\nvt -0.5 1.5\n")
        f.write("vn 0 0 1\nf 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n")
    with open(os.path.join(SCENES, "tetra.ply"), "w") as f:
        f.write(
            "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
            "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n"
        )
        f.write("0 0 1\n0.94 0 -0.33\n-0.47 0.82 -0.33\n-0.47 -0.82 -0.33\n")
        f.write("3 0 1 2\n3 0 2 3\n3 0 3 1\n3 1 3 2\n")
    quad = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    tri = [(-1, -1, 0), (1, -1, 0), (0, 1, 0)]
    serialized(
        "shapes.serialized",
        [
            (quad, [(0, 1, 2), (0, 2, 3)], None),
            (tri, [(0, 1, 2)], [(0, 0), (1, 0), (0.5, 1)]),
        ],
    )


HEAD = """<scene version="3.0.0">
    <default name="spp" value="64"/>
    <integrator type="path"><integer name="max_depth" value="{depth}"/></integrator>
"""


def sensor(
    fov=40,
    w=64,
    h=64,
    origin="0, 1.2, 4.5",
    target="0, 0.6, 0",
    extra="",
    rfilter="box",
    plugin="perspective",
):
    return f"""    <sensor type="{plugin}">
        <float name="fov" value="{fov}"/>{extra}
        <transform name="to_world"><lookat origin="{origin}" target="{target}" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm"><integer name="width" value="{w}"/><integer name="height" value="{h}"/>
            <rfilter type="{rfilter}"/></film>
    </sensor>
"""


STAGE = """    <shape type="rectangle">
        <transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.6, 0.55"/></bsdf></bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="3"/><translate z="-1.5"/></transform>
        <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.4, 0.5, 0.6"/></bsdf></bsdf>
    </shape>
"""

LIGHT = """    <shape type="rectangle">
        <transform name="to_world"><scale x="0.6" y="0.4"/><rotate x="1" angle="90"/><translate x="0.5" y="2.6" z="1"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>
        <emitter type="area"><rgb name="radiance" value="12, 11, 9"/></emitter>
    </shape>
"""


def sphere(x, y, z, r, bsdf):
    return f"""    <shape type="sphere"><point name="center" x="{x}" y="{y}" z="{z}"/><float name="radius" value="{r}"/>
        {bsdf}
    </shape>
"""


def spheres(left, middle, right):
    """Three spheres of radius 0.45 in a row on the stage, of BSDFs `left`, `middle`, `right`."""
    return "".join(
        sphere(x, 0.45, 0, 0.45, bsdf)
        for x, bsdf in zip((-1.1, 0, 1.1), (left, middle, right))
    )


def scenes() -> None:
    write(
        "onesided.xml",
        HEAD.format(depth=6)
        + sensor()
        + STAGE
        + LIGHT
        + """
    <shape type="rectangle"><transform name="to_world"><scale value="0.5"/><translate x="-0.8" y="0.6"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.3, 0.2"/></bsdf></shape>
    <shape type="rectangle"><transform name="to_world"><scale value="0.5"/><rotate y="1" angle="180"/><translate x="0.4" y="0.6"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.8, 0.3"/></bsdf></shape>
    <shape type="rectangle"><transform name="to_world"><scale value="0.3"/><rotate y="1" angle="200"/><translate x="1.3" y="0.5" z="0.5"/></transform>
        <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.3, 0.3, 0.9"/></bsdf></bsdf></shape>
    <shape type="rectangle"><transform name="to_world"><scale value="0.3"/><rotate y="1" angle="-160"/><translate x="-1.05" y="1.45" z="0.3"/></transform>
        <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.9, 0.8, 0.1"/></bsdf>
            <bsdf type="roughconductor"><string name="material" value="Au"/><float name="alpha" value="0.3"/></bsdf></bsdf></shape>
    <shape type="rectangle"><transform name="to_world"><scale value="0.3"/><rotate y="1" angle="20"/><translate x="1.05" y="1.45" z="0.3"/></transform>
        <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.9, 0.8, 0.1"/></bsdf>
            <bsdf type="diffuse"><rgb name="reflectance" value="0.1, 0.8, 0.9"/></bsdf></bsdf></shape>
</scene>
""",
    )
    write(
        "conductors.xml",
        HEAD.format(depth=6)
        + sensor()
        + STAGE
        + LIGHT
        + spheres(
            '<bsdf type="conductor"><string name="material" value="Au"/></bsdf>',
            '<bsdf type="roughconductor"><string name="material" value="Cu"/><float name="alpha" value="0.2"/></bsdf>',
            '<bsdf type="roughconductor"><string name="distribution" value="ggx"/><float name="alpha" value="0.1"/>'
            '<rgb name="eta" value="1.66, 0.88, 0.52"/><rgb name="k" value="9.2, 6.3, 4.8"/><rgb name="specular_reflectance" value="0.7, 0.8, 0.9"/></bsdf>',
        )
        + "</scene>\n",
    )
    write(
        "anisotropic.xml",
        HEAD.format(depth=4)
        + sensor(origin="0, 2.5, 2.5", target="0, 0, 0")
        + """
    <shape type="rectangle"><transform name="to_world"><scale x="0.75" y="1.5"/><rotate x="1" angle="-90"/><translate x="-0.76"/></transform>
        <bsdf type="roughconductor"><string name="distribution" value="ggx"/><float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.4"/>
            <string name="material" value="Al"/></bsdf></shape>
    <shape type="rectangle"><transform name="to_world"><scale x="0.75" y="1.5"/><rotate x="1" angle="-90"/><translate x="0.76"/></transform>
        <bsdf type="roughconductor"><float name="alpha_u" value="0.4"/><float name="alpha_v" value="0.08"/>
            <string name="material" value="Cu"/></bsdf></shape>
    <emitter type="point"><point name="position" x="0" y="1.2" z="-0.8"/><rgb name="intensity" value="4"/></emitter>
    <emitter type="constant"><rgb name="radiance" value="0.05"/></emitter>
</scene>
""",
    )
    write(
        "dielectrics.xml",
        HEAD.format(depth=12)
        + sensor()
        + STAGE
        + LIGHT
        + sphere(
            -1.1,
            0.45,
            0,
            0.45,
            '<bsdf type="dielectric"><string name="int_ior" value="bk7"/></bsdf>',
        )
        + sphere(
            0,
            0.45,
            0,
            0.45,
            '<bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="alpha" value="0.15"/><float name="int_ior" value="1.33"/></bsdf>',
        )
        + """    <shape type="rectangle"><transform name="to_world"><scale value="0.45"/><rotate y="1" angle="-20"/><translate x="1.1" y="0.5"/></transform>
        <bsdf type="thindielectric"><float name="int_ior" value="1.5"/></bsdf></shape>
    <emitter type="constant"><rgb name="radiance" value="0.3"/></emitter>
</scene>
""",
    )
    write(
        "rough_dielectrics.xml",
        HEAD.format(depth=12)
        + sensor()
        + STAGE
        + LIGHT
        + spheres(
            '<bsdf type="roughdielectric"><float name="alpha" value="0.3"/></bsdf>',
            '<bsdf type="roughdielectric"><string name="distribution" value="beckmann"/><float name="alpha" value="0.08"/>'
            '<string name="int_ior" value="water"/></bsdf>',
            '<bsdf type="roughdielectric"><float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.35"/>'
            '<float name="int_ior" value="1.7"/></bsdf>',
        )
        + """    <emitter type="constant"><rgb name="radiance" value="0.3"/></emitter>
</scene>
""",
    )
    write(
        "principled.xml",
        HEAD.format(depth=8)
        + sensor(fov=45, w=96, h=36, origin="0, 0.8, 4", target="0, 0.45, 0")
        + STAGE
        + LIGHT
        + spheres(
            '<bsdf type="principled"><rgb name="base_color" value="0.8, 0.3, 0.2"/><float name="roughness" value="0.7"/>'
            '<float name="sheen" value="1"/><float name="sheen_tint" value="0.5"/><float name="flatness" value="0.5"/></bsdf>',
            '<bsdf type="principled"><rgb name="base_color" value="0.9, 0.7, 0.3"/><float name="metallic" value="0.7"/>'
            '<float name="roughness" value="0.3"/><float name="anisotropic" value="0.6"/><float name="spec_tint" value="0.6"/></bsdf>',
            '<bsdf type="principled"><rgb name="base_color" value="0.1, 0.3, 0.8"/><float name="roughness" value="0.4"/>'
            '<float name="clearcoat" value="1"/><float name="clearcoat_gloss" value="0.8"/><float name="specular" value="0.8"/></bsdf>',
        )
        + """    <emitter type="constant"><rgb name="radiance" value="0.2"/></emitter>
</scene>
""",
    )
    write(
        "principled_glass.xml",
        HEAD.format(depth=12)
        + sensor(fov=45, w=96, h=36, origin="0, 0.8, 4", target="0, 0.45, 0")
        + STAGE
        + LIGHT
        + spheres(
            '<bsdf type="principled"><rgb name="base_color" value="0.9, 0.95, 1"/><float name="spec_trans" value="1"/>'
            '<float name="roughness" value="0.2"/><float name="eta" value="1.45"/></bsdf>',
            '<bsdf type="principled"><rgb name="base_color" value="0.3, 0.8, 0.4"/><float name="spec_trans" value="0.6"/>'
            '<float name="roughness" value="0.5"/><float name="metallic" value="0.1"/></bsdf>',
            '<bsdf type="principled"><texture type="checkerboard" name="base_color"><rgb name="color0" value="0.9, 0.2, 0.2"/>'
            '<rgb name="color1" value="0.9, 0.9, 0.9"/></texture><float name="spec_trans" value="0.4"/>'
            '<float name="roughness" value="0.35"/><float name="clearcoat" value="0.5"/></bsdf>',
        )
        + """    <emitter type="constant"><rgb name="radiance" value="0.3"/></emitter>
</scene>
""",
    )
    write(
        "textured_numbers.xml",
        HEAD.format(depth=10)
        + sensor(fov=45, w=96, h=48, origin="0, 0.9, 4", target="0, 0.55, 0")
        + STAGE
        + LIGHT
        + """    <texture type="checkerboard" id="alpha_checks"><rgb name="color0" value="0.03"/><rgb name="color1" value="0.4"/>
        <transform name="to_uv"><scale x="6" y="4"/></transform></texture>
    <shape type="rectangle"><transform name="to_world"><scale x="2" y="0.4"/><translate y="1.45" z="-1.2"/></transform>
        <bsdf type="blendbsdf"><texture type="checkerboard" name="weight"><rgb name="color0" value="0.1"/><rgb name="color1" value="0.9"/>
            <transform name="to_uv"><scale x="5" y="1"/></transform></texture>
            <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.2, 0.1"/></bsdf>
            <bsdf type="diffuse"><rgb name="reflectance" value="0.1, 0.3, 0.8"/></bsdf></bsdf></shape>
"""
        + spheres(
            '<bsdf type="roughconductor"><string name="material" value="Au"/><ref name="alpha_u" id="alpha_checks"/>'
            '<float name="alpha_v" value="0.15"/><texture type="checkerboard" name="specular_reflectance">'
            '<rgb name="color0" value="1, 1, 1"/><rgb name="color1" value="0.3, 0.6, 0.9"/>'
            '<transform name="to_uv"><scale x="3" y="2"/></transform></texture></bsdf>',
            '<bsdf type="principled"><rgb name="base_color" value="0.8, 0.5, 0.3"/>'
            '<texture type="bitmap" name="roughness"><string name="filename" value="bumps.png"/><boolean name="raw" value="true"/>'
            '<transform name="to_uv"><scale x="2" y="2"/></transform></texture>'
            '<texture type="checkerboard" name="metallic"><rgb name="color0" value="0"/><rgb name="color1" value="1"/>'
            '<transform name="to_uv"><scale x="4" y="3"/></transform></texture></bsdf>',
            '<bsdf type="roughdielectric"><string name="distribution" value="ggx"/><ref name="alpha" id="alpha_checks"/></bsdf>',
        )
        + """    <emitter type="constant"><rgb name="radiance" value="0.3"/></emitter>
</scene>
""",
    )
    write(
        "plastics.xml",
        HEAD.format(depth=6)
        + sensor()
        + STAGE
        + LIGHT
        + spheres(
            '<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.7, 0.15, 0.1"/></bsdf>',
            '<bsdf type="roughplastic"><float name="alpha" value="0.2"/><boolean name="nonlinear" value="true"/>'
            '<rgb name="diffuse_reflectance" value="0.1, 0.5, 0.7"/></bsdf>',
            '<bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="0.05"/>'
            '<texture type="bitmap" name="diffuse_reflectance"><string name="filename" value="checks.png"/></texture></bsdf>',
        )
        + "</scene>\n",
    )
    write(
        "textures.xml",
        HEAD.format(depth=4)
        + sensor(origin="0, 0, 4", target="0, 0, 0")
        + """
    <texture type="bitmap" id="checks"><string name="filename" value="checks.png"/></texture>
    <shape type="obj"><string name="filename" value="quad_uv2.obj"/>
        <transform name="to_world"><scale value="0.7"/><translate x="-0.75" y="0.75"/></transform>
        <bsdf type="diffuse"><ref id="checks" name="reflectance"/></bsdf></shape>
    <shape type="obj"><string name="filename" value="quad_uv2.obj"/>
        <transform name="to_world"><scale value="0.7"/><translate x="0.75" y="0.75"/></transform>
        <bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="checks.png"/>
            <string name="wrap_mode" value="mirror"/><boolean name="raw" value="true"/></texture></bsdf></shape>
    <shape type="obj"><string name="filename" value="quad_uv2.obj"/>
        <transform name="to_world"><scale value="0.7"/><translate x="-0.75" y="-0.75"/></transform>
        <bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="checks.png"/>
            <string name="wrap_mode" value="clamp"/><string name="filter_type" value="nearest"/></texture></bsdf></shape>
    <shape type="rectangle"><transform name="to_world"><scale value="0.7"/><translate x="0.75" y="-0.75"/></transform>
        <bsdf type="diffuse"><texture type="checkerboard" name="reflectance"><rgb name="color0" value="0.8, 0.7, 0.1"/>
            <rgb name="color1" value="0.1, 0.2, 0.6"/>
            <transform name="to_uv"><scale x="3" y="2"/><translate x="0.25"/></transform></texture></bsdf></shape>
    <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>
""",
    )
    write(
        "cutouts.xml",
        HEAD.format(depth=12)
        + sensor()
        + STAGE
        + LIGHT
        + sphere(
            -1.1,
            0.45,
            0,
            0.45,
            '<bsdf type="mask"><float name="opacity" value="0.4"/><bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.2, 0.2"/></bsdf></bsdf>',
        )
        + sphere(
            0,
            0.45,
            0,
            0.45,
            '<bsdf type="blendbsdf"><float name="weight" value="0.3"/><bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.7, 0.2"/></bsdf>'
            '<bsdf type="roughconductor"><string name="material" value="Ag"/><float name="alpha" value="0.15"/></bsdf></bsdf>',
        )
        + sphere(1.1, 0.45, 0, 0.45, '<bsdf type="null"/>')
        + """    <shape type="rectangle"><transform name="to_world"><scale value="0.5"/><translate x="1.1" y="1.4"/></transform>
        <bsdf type="mask"><texture type="bitmap" name="opacity"><string name="filename" value="checks.png"/><boolean name="raw" value="true"/></texture>
            <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.9"/></bsdf></bsdf></bsdf></shape>
</scene>
""",
    )
    # Under a directional light a mask's shadow is solid: Mitsuba's shadow rays stop at the
    # masked surface, holes included, and no other path reaches a delta light.
    write(
        "mask_shadow.xml",
        HEAD.format(depth=6)
        + sensor()
        + STAGE
        + """    <emitter type="directional"><vector name="direction" x="0.35" y="-1" z="-0.25"/><rgb name="irradiance" value="3, 2.8, 2.5"/></emitter>
    <emitter type="constant"><rgb name="radiance" value="0.15"/></emitter>
"""
        + sphere(
            -0.9,
            0.45,
            0.2,
            0.45,
            '<bsdf type="mask"><float name="opacity" value="0.3"/><bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.2, 0.2"/></bsdf></bsdf>',
        )
        + """    <shape type="rectangle"><transform name="to_world"><scale value="0.5"/><rotate x="1" angle="-90"/><translate x="0.5" y="0.8" z="0.3"/></transform>
        <bsdf type="mask"><texture type="bitmap" name="opacity"><string name="filename" value="checks.png"/><boolean name="raw" value="true"/></texture>
            <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.9"/></bsdf></bsdf></bsdf></shape>
</scene>
""",
    )
    tw = '<bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="{}"/></bsdf></bsdf>'
    write(
        "shapes.xml",
        HEAD.format(depth=5)
        + sensor(fov=50, origin="0, 2, 5", target="0, 0.5, 0")
        + STAGE
        + LIGHT
        + f"""
    <shape type="cube"><transform name="to_world"><scale value="0.3"/><rotate y="1" angle="30"/><translate x="-1.3" y="0.3" z="0.3"/></transform>{tw.format("0.8, 0.4, 0.2")}</shape>
    <shape type="disk"><transform name="to_world"><scale value="0.35"/><rotate x="1" angle="-60"/><translate x="-0.5" y="0.4" z="0.6"/></transform>{tw.format("0.2, 0.6, 0.8")}</shape>
    <shape type="cylinder"><point name="p0" x="0.4" y="0" z="0.5"/><point name="p1" x="0.4" y="0.8" z="0.3"/><float name="radius" value="0.2"/>{tw.format("0.7, 0.7, 0.2")}</shape>
    <shape type="obj"><string name="filename" value="octa.obj"/><boolean name="face_normals" value="true"/>
        <transform name="to_world"><scale value="0.35"/><translate x="1.2" y="0.35" z="0.4"/></transform>{tw.format("0.6, 0.3, 0.7")}</shape>
    <shape type="obj"><string name="filename" value="octa.obj"/>
        <transform name="to_world"><scale value="0.3"/><translate x="-1" y="1.3" z="-0.6"/></transform>{tw.format("0.9, 0.9, 0.9")}</shape>
    <shape type="ply"><string name="filename" value="tetra.ply"/>
        <transform name="to_world"><scale value="0.35"/><translate x="0" y="1.4" z="-0.5"/></transform>{tw.format("0.3, 0.8, 0.4")}</shape>
    <shape type="serialized"><string name="filename" value="shapes.serialized"/><integer name="shape_index" value="1"/>
        <transform name="to_world"><scale value="0.3"/><translate x="1" y="1.3" z="-0.6"/></transform>{tw.format("0.8, 0.8, 0.3")}</shape>
    <shape type="shapegroup" id="pair">
        <shape type="sphere"><float name="radius" value="0.12"/>{tw.format("0.9, 0.5, 0.5")}</shape>
        <shape type="sphere"><point name="center" x="0.3" y="0" z="0"/><float name="radius" value="0.08"/>{tw.format("0.5, 0.9, 0.5")}</shape>
    </shape>
    <shape type="instance"><ref id="pair"/><transform name="to_world"><translate x="-0.2" y="0.12" z="1.2"/></transform></shape>
    <shape type="instance"><ref id="pair"/><transform name="to_world"><rotate y="1" angle="90"/><translate x="0.5" y="0.12" z="1.3"/></transform></shape>
    <shape type="disk"><boolean name="flip_normals" value="true"/>
        <transform name="to_world"><scale value="0.2"/><rotate x="1" angle="90"/><translate x="1.6" y="1.8" z="0.5"/></transform>
        <emitter type="area"><rgb name="radiance" value="6"/></emitter></shape>
</scene>
""",
    )
    write(
        "emitters.xml",
        HEAD.format(depth=5)
        + sensor()
        + STAGE
        + sphere(0, 0.45, 0, 0.45, tw.format("0.7, 0.7, 0.7"))
        + """
    <emitter type="point"><point name="position" x="-1.2" y="1.5" z="1"/><rgb name="intensity" value="2, 1.5, 1"/></emitter>
    <emitter type="spot"><transform name="to_world"><lookat origin="1.5, 2.5, 1" target="0.3, 0, 0"/></transform>
        <rgb name="intensity" value="6, 8, 10"/><float name="cutoff_angle" value="25"/><float name="beam_width" value="12"/></emitter>
    <emitter type="directional"><vector name="direction" x="0.3" y="-1" z="-0.4"/><rgb name="irradiance" value="0.4, 0.35, 0.3"/></emitter>
</scene>
""",
    )
    # The same scene under the sky as stored (Rec. 709) and stored as Adobe RGB.
    for name, sky in (("envmap.xml", "sky.exr"), ("envmap_adobe.xml", "sky_adobe.exr")):
        write(
            name,
            HEAD.format(depth=5)
            + sensor()
            + """
    <shape type="rectangle">
        <transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></bsdf>
    </shape>
"""
            + sphere(-0.6, 0.45, 0, 0.45, tw.format("0.8"))
            + sphere(0.6, 0.45, 0, 0.45, '<bsdf type="conductor"/>')
            + f"""
    <emitter type="envmap"><string name="filename" value="{sky}"/><float name="scale" value="1.5"/>
        <transform name="to_world"><rotate y="1" angle="40"/></transform></emitter>
</scene>
""",
        )
    write(
        "camera.xml",
        HEAD.format(depth=5)
        + sensor(
            fov=30,
            w=80,
            h=48,
            rfilter="gaussian",
            plugin="thinlens",
            extra='\n        <string name="fov_axis" value="smaller"/><float name="aperture_radius" value="0.08"/><float name="focus_distance" value="4.5"/>',
        )
        + STAGE
        + LIGHT
        + sphere(-0.8, 0.45, 0, 0.45, tw.format("0.8, 0.3, 0.2"))
        + sphere(0.6, 0.3, 1.5, 0.3, tw.format("0.2, 0.3, 0.8"))
        + "</scene>\n",
    )
    write(
        "focal_length.xml",
        (HEAD.format(depth=5) + sensor(w=48, h=64, rfilter="tent")).replace(
            '<float name="fov" value="40"/>',
            '<string name="focal_length" value="35mm"/>',
        )
        + STAGE
        + LIGHT
        + sphere(0, 0.45, 0, 0.45, tw.format("0.8, 0.6, 0.2"))
        + "</scene>\n",
    )
    write(
        "bumpmap.xml",
        HEAD.format(depth=4)
        + sensor(origin="0, 2.5, 2.5", target="0, 0, 0")
        + """
    <shape type="rectangle"><transform name="to_world"><scale value="1.2"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="bumpmap"><float name="scale" value="0.1"/>
            <texture type="bitmap"><string name="filename" value="bumps.png"/><boolean name="raw" value="true"/></texture>
            <bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="0.15"/>
                <rgb name="diffuse_reflectance" value="0.2, 0.4, 0.6"/></bsdf></bsdf></shape>
    <emitter type="point"><point name="position" x="-1.5" y="1" z="0.3"/><rgb name="intensity" value="5"/></emitter>
    <emitter type="constant"><rgb name="radiance" value="0.05"/></emitter>
</scene>
""",
    )
    write(
        "version_06.xml",
        """<scene version="0.6.0">
    <default name="spp" value="64"/>
    <integrator type="path"><integer name="maxDepth" value="6"/></integrator>
    <sensor type="perspective"><float name="fov" value="40"/>
        <transform name="toWorld"><lookat origin="0, 1.2, 4.5" target="0, 0.6, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sampleCount" value="$spp"/></sampler>
        <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="64"/><rfilter type="box"/></film>
    </sensor>
"""
        + STAGE.replace("to_world", "toWorld")
        + LIGHT.replace("to_world", "toWorld")
        + sphere(
            -0.6,
            0.45,
            0,
            0.45,
            '<bsdf type="diffuse"><rgb name="diffuseReflectance" value="0.2, 0.6, 0.8"/></bsdf>',
        )
        + sphere(
            0.6,
            0.45,
            0,
            0.45,
            '<bsdf type="roughplastic"><float name="intIOR" value="1.6"/><float name="alpha" value="0.1"/>'
            '<rgb name="diffuseReflectance" value="0.8, 0.4, 0.1"/></bsdf>',
        )
        + "</scene>\n",
    )
    write(
        "normalmap.xml",
        HEAD.format(depth=4)
        + sensor(origin="0, 2.5, 2.5", target="0, 0, 0")
        + """
    <shape type="rectangle"><transform name="to_world"><scale value="1.2"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="normalmap"><texture type="bitmap" name="normalmap"><string name="filename" value="ridges.png"/><boolean name="raw" value="true"/></texture>
            <bsdf type="roughconductor"><string name="material" value="Al"/><float name="alpha" value="0.2"/></bsdf></bsdf></shape>
    <emitter type="point"><point name="position" x="-1.5" y="1" z="0.3"/><rgb name="intensity" value="5"/></emitter>
    <emitter type="constant"><rgb name="radiance" value="0.05"/></emitter>
</scene>
""",
    )


def wall(z0, z1, y0, y1, x):
    """A rectangle of the plane x = `x` over z in [z0, z1] and y in [y0, y1] (2% larger, so
    that no crack opens where it meets its neighbours), grey, two-sided."""
    return f"""    <shape type="rectangle">
        <transform name="to_world"><scale x="{(z1 - z0) / 2 * 1.02}" y="{(y1 - y0) / 2 * 1.02}"/><rotate y="1" angle="90"/><translate x="{x}" y="{(y0 + y1) / 2}" z="{(z0 + z1) / 2}"/></transform>
        <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.6"/></bsdf></bsdf>
    </shape>
"""


def window_room() -> None:
    """A closed 2×2×2 room lit only by the sky through a window in its left wall (the case
    learned environment sampling is for). Its walls overlap a little at the edges."""
    slab = """    <shape type="rectangle">
        <transform name="to_world"><scale value="1.02"/>{t}</transform>
        <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="{c}"/></bsdf></bsdf>
    </shape>
"""
    floor = slab.format(t='<rotate x="1" angle="-90"/>', c="0.5, 0.45, 0.4")
    ceiling = slab.format(t='<rotate x="1" angle="90"/><translate y="2"/>', c="0.7")
    back = slab.format(t='<translate y="1" z="-1"/>', c="0.4, 0.5, 0.6")
    front = slab.format(t='<translate y="1" z="1"/>', c="0.6")
    right = slab.format(
        t='<rotate y="1" angle="-90"/><translate x="1" y="1"/>', c="0.6, 0.5, 0.4"
    )
    left = (
        wall(-1, 1, 0, 0.8, -1)
        + wall(-1, 1, 1.6, 2, -1)
        + wall(0.2, 1, 0.8, 1.6, -1)
        + wall(-1, -0.6, 0.8, 1.6, -1)
    )
    write(
        "window_room.xml",
        HEAD.format(depth=6)
        + sensor(fov=75, w=48, h=48, origin="0.7, 1.1, 0.9", target="-0.4, 0.7, -1")
        + floor
        + ceiling
        + back
        + front
        + right
        + left
        + sphere(
            0.3,
            0.35,
            -0.4,
            0.35,
            '<bsdf type="diffuse"><rgb name="reflectance" value="0.8"/></bsdf>',
        )
        + """    <emitter type="envmap"><string name="filename" value="sky.exr"/><float name="scale" value="2"/>
        <transform name="to_world"><rotate y="1" angle="150"/></transform></emitter>
</scene>
""",
    )


VOLPATH = HEAD.replace('type="path"', 'type="volpath"')


def media() -> None:
    """Homogeneous media: a chromatic forward-scattering fog bounded by a null cube with a
    small emitter inside it and the stage's light outside (`media_fog`), and a glass sphere
    of chromatic water-like medium, with a chromatic absorbing-only medium in a second
    sphere bounded by a null surface (`media_glass`)."""
    write(
        "media_fog.xml",
        VOLPATH.format(depth=12)
        + sensor()
        + STAGE
        + LIGHT
        + """    <medium type="homogeneous" id="fog">
        <rgb name="albedo" value="0.9, 0.7, 0.5"/>
        <rgb name="sigma_t" value="0.375, 0.625, 1.0"/>
        <float name="scale" value="2.4"/>
        <phase type="hg"><float name="g" value="0.6"/></phase>
    </medium>
    <shape type="cube">
        <transform name="to_world"><scale x="0.9" y="0.6" z="0.6"/><translate y="0.65"/></transform>
        <bsdf type="null"/>
        <ref name="interior" id="fog"/>
    </shape>
    <shape type="sphere"><point name="center" x="-0.3" y="0.7" z="0.1"/><float name="radius" value="0.1"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>
        <emitter type="area"><rgb name="radiance" value="20, 16, 10"/></emitter>
        <ref name="exterior" id="fog"/>
    </shape>
    <emitter type="constant"><rgb name="radiance" value="0.1"/></emitter>
</scene>
""",
    )
    write(
        "media_glass.xml",
        VOLPATH.format(depth=16)
        + sensor()
        + STAGE
        + LIGHT
        + """    <medium type="homogeneous" id="water">
        <rgb name="albedo" value="0.3, 0.8, 0.95"/>
        <volume type="constvolume" name="sigma_t"><rgb name="value" value="1.0, 0.6, 0.4"/></volume>
        <float name="scale" value="2"/>
        <phase type="isotropic"/>
    </medium>
    <shape type="sphere"><point name="center" x="-0.5" y="0.45" z="0"/><float name="radius" value="0.45"/>
        <bsdf type="dielectric"><float name="int_ior" value="1.33"/></bsdf>
        <ref name="interior" id="water"/>
    </shape>
    <shape type="sphere"><point name="center" x="0.6" y="0.4" z="0.2"/><float name="radius" value="0.4"/>
        <bsdf type="null"/>
        <medium type="homogeneous" name="interior">
            <rgb name="albedo" value="0"/>
            <rgb name="sigma_t" value="0.125, 0.5, 1.0"/>
            <float name="scale" value="4"/>
        </medium>
    </shape>
    <emitter type="constant"><rgb name="radiance" value="0.3"/></emitter>
</scene>
""",
    )


SMOKE_RES = (12, 10, 10)
SMOKE_ALBEDO = (0.95, 0.85, 0.7)


def smoke_grid() -> np.ndarray:
    """The chromatic extinction grid of `media_smoke` (z, y, x, rgb; at most 1): three
    Gaussian blobs whose colour drifts across the box, zero on the outer voxel layer (so that
    Mitsuba's clamped edges and pbrt-v4's faded ones agree)."""
    nx, ny, nz = SMOKE_RES
    z, y, x = np.meshgrid(
        (np.arange(nz) + 0.5) / nz,
        (np.arange(ny) + 0.5) / ny,
        (np.arange(nx) + 0.5) / nx,
        indexing="ij",
    )
    density = np.zeros_like(x)
    for cx, cy, cz, r in [
        (0.35, 0.4, 0.5, 0.22),
        (0.65, 0.55, 0.45, 0.18),
        (0.5, 0.3, 0.6, 0.15),
    ]:
        density += np.exp(
            -((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) / (2 * r * r)
        )
    density /= density.max()
    colour = np.stack([np.ones_like(x), 0.7 + 0.3 * x, 0.4 + 0.6 * y], axis=-1)
    grid = density[..., None] * colour
    grid[0, :, :] = grid[-1, :, :] = 0
    grid[:, 0, :] = grid[:, -1, :] = 0
    grid[:, :, 0] = grid[:, :, -1] = 0
    return grid.astype(np.float32)


def smoke() -> None:
    """A heterogeneous medium: a chromatic extinction grid (`media_smoke.vol`) with an RGB
    albedo and forward scattering in a null box on the stage (`media_smoke.xml`), and its
    pbrt-v4 form as an `rgbgrid` (`tests/pbrt/scenes/media_smoke.pbrt`)."""
    grid = smoke_grid()
    nx, ny, nz = SMOKE_RES
    header = b"VOL" + bytes([3]) + struct.pack("<iiiii", 1, nx, ny, nz, 3)
    header += struct.pack("<6f", 0, 0, 0, 1, 1, 1)
    with open(os.path.join(SCENES, "media_smoke.vol"), "wb") as f:
        f.write(header + grid.astype("<f4").tobytes())
    albedo = ", ".join(str(a) for a in SMOKE_ALBEDO)
    write(
        "media_smoke.xml",
        VOLPATH.format(depth=12)
        + sensor()
        + STAGE
        + LIGHT
        + f"""    <medium type="heterogeneous" id="smoke">
        <volume type="gridvolume" name="sigma_t">
            <string name="filename" value="media_smoke.vol"/>
            <transform name="to_world"><scale x="1.8" y="1.2" z="1.2"/><translate x="-0.9" y="0.05" z="-0.6"/></transform>
        </volume>
        <rgb name="albedo" value="{albedo}"/>
        <float name="scale" value="8"/>
        <phase type="hg"><float name="g" value="0.4"/></phase>
    </medium>
    <shape type="cube">
        <transform name="to_world"><scale x="0.9" y="0.6" z="0.6"/><translate y="0.65"/></transform>
        <bsdf type="null"/>
        <ref name="interior" id="smoke"/>
    </shape>
    <emitter type="constant"><rgb name="radiance" value="0.1"/></emitter>
</scene>
""",
    )
    albedo = np.array(SMOKE_ALBEDO, dtype=np.float64)

    def values(g: np.ndarray) -> str:
        flat = [f"{v:.6g}" for v in g.reshape(-1)]
        return "\n    ".join(
            " ".join(flat[i : i + 24]) for i in range(0, len(flat), 24)
        )

    pbrt = os.path.join(HERE, "..", "pbrt", "scenes", "media_smoke.pbrt")
    with open(os.path.join(HERE, "..", "pbrt", "scenes", "media_fog.pbrt")) as f:
        stage = f.read()
    stage = stage[stage.index("\nScale -1 1 1\n") + 1 : stage.index("MakeNamedMedium")]
    with open(pbrt, "w") as f:
        f.write(
            "# A test scene of the pbrt-v4 reader (see tests/pbrt/README.md), written by\n"
            "# tests/mitsuba/make.py: the pbrt-v4 form of tests/mitsuba/scenes/media_smoke.xml as an\n"
            "# rgbgrid (sigma_a = (1 - albedo) sigma_t, sigma_s = albedo sigma_t per voxel), which\n"
            "# must give the same image.\n"
            + stage
            + 'MakeNamedMedium "smoke" "string type" [ "rgbgrid" ] "float g" [ 0.4 ] "float scale" [ 8 ]\n'
            + f'  "integer nx" [ {nx} ] "integer ny" [ {ny} ] "integer nz" [ {nz} ]\n'
            + '  "point3 p0" [ -0.9 0.05 -0.6 ] "point3 p1" [ 0.9 1.25 0.6 ]\n'
            + f'  "rgb sigma_a" [\n    {values(grid * (1 - albedo))} ]\n'
            + f'  "rgb sigma_s" [\n    {values(grid * albedo)} ]\n'
            + "AttributeBegin\n"
            + '  MediumInterface "smoke" ""\n'
            + '  Material "interface"\n'
            + '  Shape "trianglemesh" "point3 P" [ -0.9 0.05 -0.6  0.9 0.05 -0.6  0.9 1.25 -0.6  '
            + "-0.9 1.25 -0.6  -0.9 0.05 0.6  0.9 0.05 0.6  0.9 1.25 0.6  -0.9 1.25 0.6 ]\n"
            + '    "integer indices" [ 0 2 1 0 3 2 4 5 6 4 6 7 0 1 5 0 5 4 3 6 2 3 7 6 0 4 7 0 7 3 1 2 6 1 6 5 ]\n'
            + "AttributeEnd\n"
            + 'LightSource "infinite" "rgb L" [ 0.1 0.1 0.1 ]\n'
        )


def refs(spp: int, only: list) -> None:
    tool = os.path.join(HERE, "..", "..", "..", "shared", "tools", "mitsuba_xml.py")
    for name in sorted(os.listdir(SCENES)):
        if name.endswith(".xml") and (not only or name[:-4] in only):
            out = os.path.join(REFS, name[:-4] + ".exr")
            print(name, flush=True)
            subprocess.run(
                [
                    sys.executable,
                    tool,
                    os.path.join(SCENES, name),
                    "--spp",
                    str(spp),
                    "--out",
                    out,
                ],
                check=True,
            )


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--refs", action="store_true")
    ap.add_argument("--spp", type=int, default=16384)
    ap.add_argument(
        "--only", nargs="*", default=[], help="scene names whose references to make"
    )
    a = ap.parse_args()
    os.makedirs(SCENES, exist_ok=True)
    os.makedirs(REFS, exist_ok=True)
    assets()
    scenes()
    window_room()
    media()
    smoke()
    if a.refs:
        refs(a.spp, a.only)
