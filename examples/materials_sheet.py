"""The glTF materials the renderer reads, in one picture (docs/materials.png).

Writes a small glTF scene of its own (spheres and a textured ground plane, with a camera) and
renders it lit by the studio environment map: smooth glass, rough tinted glass
(``KHR_materials_transmission`` + ``KHR_materials_ior``), rough gold (metallic-roughness),
a plastic with a normal map, and a metallic-roughness texture striping metal and
dielectric. Run after ``pip install ./python``::

    python examples/materials_sheet.py [--shared ../shared] [-o docs/materials.png]
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
from pathlib import Path

import numpy as np
import pathtracer as pt

ROOT = Path(__file__).resolve().parents[1]


def sphere(n_lat: int = 48, n_lon: int = 96) -> tuple[np.ndarray, ...]:
    """A unit-radius UV sphere: positions (= normals), texture coordinates (v from the north
    pole down) and triangles wound counter-clockwise seen from outside (glTF's front)."""
    pos, uv = [], []
    for i in range(n_lat + 1):
        t = math.pi * i / n_lat
        for j in range(n_lon + 1):
            p = 2 * math.pi * j / n_lon
            pos.append((math.sin(t) * math.cos(p), math.cos(t), -math.sin(t) * math.sin(p)))
            uv.append((j / n_lon, i / n_lat))
    pos_a = np.array(pos, np.float32)
    tris = []
    for i in range(n_lat):
        for j in range(n_lon):
            a, b = i * (n_lon + 1) + j, (i + 1) * (n_lon + 1) + j
            for t in ((a, b, a + 1), (a + 1, b, b + 1)):
                v = pos_a[list(t)]
                c = np.cross(v[1] - v[0], v[2] - v[0])
                if np.linalg.norm(c) < 1e-9:
                    continue
                tris.append(t if np.dot(c, v.mean(axis=0)) > 0 else (t[0], t[2], t[1]))
    return pos_a, pos_a.copy(), np.array(uv, np.float32), np.array(tris, np.uint32)


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def write_data_png(path: Path, values: np.ndarray) -> None:
    """A PNG whose stored values are ``values`` (in [0, 1]): ``write_image`` encodes linear
    values to sRGB, so the data is decoded first."""
    pt.write_image(path, srgb_to_linear(np.clip(values, 0, 1)).astype(np.float32))


def build(dir: Path) -> Path:
    s_pos, s_nrm, s_uv, s_idx = sphere()
    g_pos = np.array([[-6, 0, -6], [6, 0, -6], [6, 0, 6], [-6, 0, 6]], np.float32)
    g_nrm = np.tile(np.array([0, 1, 0], np.float32), (4, 1))
    g_uv = np.array([[0, 0], [6, 0], [6, 6], [0, 6]], np.float32)
    g_idx = np.array([[0, 2, 1], [0, 3, 2]], np.uint32)
    arrays = [s_pos, s_nrm, s_uv, s_idx, g_pos, g_nrm, g_uv, g_idx]
    blob, views, accessors = b"", [], []
    for a in arrays:
        data = a.tobytes()
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
        acc = {
            "bufferView": len(views) - 1,
            "componentType": 5125 if a.dtype == np.uint32 else 5126,
            "count": a.size if a.dtype == np.uint32 else a.shape[0],
            "type": "SCALAR" if a.dtype == np.uint32 else f"VEC{a.shape[1]}",
        }
        if len(accessors) in (0, 4):
            acc["min"], acc["max"] = a.min(axis=0).tolist(), a.max(axis=0).tolist()
        accessors.append(acc)
        blob += data + b"\0" * (-len(data) % 4)
    (dir / "materials.bin").write_bytes(blob)

    # Ground: a grey checker. Normal map: round bumps. Metallic-roughness: stripes of metal.
    n = 256
    y, x = np.mgrid[0:n, 0:n] / n
    checker = ((np.floor(x * 2) + np.floor(y * 2)) % 2)[..., None] * 0.35 + 0.45
    pt.write_image(dir / "checker.png", np.repeat(checker, 3, axis=2).astype(np.float32))
    fx, fy = np.sin(2 * math.pi * 12 * x), np.sin(2 * math.pi * 6 * y)
    nx, ny = -0.3 * np.cos(2 * math.pi * 12 * x) * fy, -0.3 * fx * np.cos(2 * math.pi * 6 * y)
    nz = np.ones_like(nx)
    normal = np.stack([nx, ny, nz], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    write_data_png(dir / "bumps.png", normal * 0.5 + 0.5)
    stripes = (np.floor(x * 8) % 2)
    mr = np.stack([np.zeros_like(x), 0.15 + 0.5 * (1 - stripes), stripes], axis=-1)
    write_data_png(dir / "stripes.png", mr)

    def pbr(**kw: object) -> dict:
        return {"metallicFactor": 0.0, **kw}

    materials = [
        {"name": "ground", "pbrMetallicRoughness": pbr(baseColorTexture={"index": 0}, roughnessFactor=0.8)},
        {
            "name": "glass",
            "pbrMetallicRoughness": pbr(roughnessFactor=0.0),
            "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5}},
        },
        {
            "name": "rough tinted glass",
            "pbrMetallicRoughness": pbr(baseColorFactor=[0.75, 0.9, 1.0, 1.0], roughnessFactor=0.35),
            "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.45}},
        },
        {"name": "gold", "pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.78, 0.34, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.25}},
        {
            "name": "bumpy plastic",
            "pbrMetallicRoughness": pbr(baseColorFactor=[0.15, 0.3, 0.8, 1.0], roughnessFactor=0.3),
            "normalTexture": {"index": 1},
        },
        {
            "name": "striped metal",
            "pbrMetallicRoughness": {
                "baseColorFactor": [0.9, 0.45, 0.3, 1.0],
                "metallicFactor": 1.0,
                "roughnessFactor": 1.0,
                "metallicRoughnessTexture": {"index": 2},
            },
        },
    ]
    spheres = [(m, -2.4 + 1.2 * k) for k, m in enumerate(range(1, 6))]
    meshes = [
        {"primitives": [{"attributes": {"POSITION": 4, "NORMAL": 5, "TEXCOORD_0": 6}, "indices": 7, "material": 0}]}
    ] + [
        {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": m}]}
        for m, _ in spheres
    ]
    pitch = -math.atan2(1.0, 6.5)
    nodes = [{"mesh": 0}] + [
        {"mesh": k + 1, "translation": [xc, 0.5, 0], "scale": [0.5, 0.5, 0.5]} for k, (_, xc) in enumerate(spheres)
    ] + [
        {
            "camera": 0,
            "translation": [0, 1.5, 6.5],
            "rotation": [math.sin(pitch / 2), 0, 0, math.cos(pitch / 2)],
        }
    ]
    doc = {
        "asset": {"version": "2.0", "generator": "pathtracer examples/materials_sheet.py"},
        "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior"],
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {"yfov": math.radians(30), "znear": 0.1, "aspectRatio": 16 / 9}}],
        "meshes": meshes,
        "materials": materials,
        "textures": [{"source": i, "sampler": 0} for i in range(3)],
        "samplers": [{"wrapS": 10497, "wrapT": 10497}],
        "images": [{"uri": "checker.png"}, {"uri": "bumps.png"}, {"uri": "stripes.png"}],
        "buffers": [{"byteLength": len(blob), "uri": "materials.bin"}],
        "bufferViews": views,
        "accessors": accessors,
    }
    f = dir / "materials.gltf"
    f.write_text(json.dumps(doc, indent=1))
    return f


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--shared", default=str(ROOT.parent / "shared"))
    p.add_argument("-o", "--output", default=str(ROOT / "docs/materials.png"))
    p.add_argument("--spp", type=int, default=128)
    p.add_argument("--keep", help="also copy the generated scene into this folder")
    a = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        f = build(Path(tmp))
        if a.keep:
            for g in Path(tmp).iterdir():
                (Path(a.keep) / g.name).write_bytes(g.read_bytes())
        scene = pt.load(f, env=Path(a.shared) / "envmaps/studio.exr")
        for w in scene.warnings:
            print("warning:", w)
        img = pt.render(scene, spp=a.spp, max_depth=16, width=960, height=540)
    pt.write_image(a.output, np.clip(img, 0.0, 1.0))
    print(f"wrote {a.output}")


if __name__ == "__main__":
    main()
