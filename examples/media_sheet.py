"""The participating-media figure (docs/media.png): this renderer beside the other renderers'
images of the same files.

Rows: Bitterli's volumetric-caustic (pbrt-v4 file) at 128×128, this renderer beside pbrt-v4's
own bidirectional render (``--pbrt-ref``, made as docs/media.md says) and Tungsten's
reference (``../shared/refs/bitterli``, averaged down); then the project's medium test
scenes beside Mitsuba's references (``tests/mitsuba/refs``), and for the grid scene
(``media_smoke``) also pbrt-v4's render of its pbrt-v4 form (``tests/pbrt/refs``). Run from
the project's root after ``cargo build --release``::

    python examples/media_sheet.py --pbrt-ref VC_PBRT.exr [--shared ../shared] [--spp 4096]
                                   [-o docs/media.png]
"""

from __future__ import annotations

import argparse
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import OpenEXR
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
BIN = ROOT / "target" / "release" / "pathtracer"
TILE = 192


def load(path: Path) -> np.ndarray:
    """An EXR's RGB as float32 rows × columns × 3."""
    with OpenEXR.File(str(path)) as f:
        ch = f.channels()
        if "RGB" in ch:
            return np.asarray(ch["RGB"].pixels, np.float32)
        if "RGBA" in ch:
            return np.asarray(ch["RGBA"].pixels[..., :3], np.float32)
        return np.stack([ch[c].pixels for c in "RGB"], -1).astype(np.float32)


def down(img: np.ndarray, h: int) -> np.ndarray:
    """`img` averaged down to `h` rows (its size a multiple of `h`)."""
    k = img.shape[0] // h
    return img.reshape(h, k, img.shape[1] // k, k, 3).mean((1, 3)) if k > 1 else img


def tile(img: np.ndarray) -> np.ndarray:
    """sRGB 8-bit, scaled to TILE rows by nearest pixels."""
    x = np.clip(img, 0, None)
    x = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    ys = (np.arange(TILE) * img.shape[0] / TILE).astype(int)
    xs = (np.arange(TILE) * img.shape[1] / TILE).astype(int)
    return (np.clip(x[ys][:, xs], 0, 1) * 255).astype(np.uint8)


def render(
    scene: Path, out: Path, spp: int, size: tuple[int, int] | None
) -> np.ndarray:
    """This renderer's image of `scene` at `spp` (and `size`, if given)."""
    args = [str(BIN), "-t", "2", "-s", str(spp), "-f", str(out), str(scene)]
    if size:
        args[1:1] = ["-r", str(size[0]), str(size[1])]
    subprocess.run(args, check=True, capture_output=True)
    return load(out)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--pbrt-ref", type=Path, required=True)
    ap.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    ap.add_argument("--spp", type=int, default=4096)
    ap.add_argument("-o", type=Path, default=ROOT / "docs" / "media.png")
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp())
    vc = a.shared / "scenes/pbrt-v4/volumetric-caustic/scene-v4.pbrt"
    rows = [
        [
            render(vc, tmp / "vc.exr", a.spp, (128, 128)),
            load(a.pbrt_ref),
            down(load(a.shared / "refs/bitterli/volumetric-caustic.exr"), 128),
        ]
    ]
    for name in ("media_fog", "media_glass", "media_smoke"):
        scene = ROOT / "tests/mitsuba/scenes" / f"{name}.xml"
        ref = load(ROOT / "tests/mitsuba/refs" / f"{name}.exr")
        row = [render(scene, tmp / f"{name}.exr", a.spp, None), ref]
        pbrt_ref = ROOT / "tests/pbrt/refs" / f"{name}.exr"
        if name == "media_smoke":
            row.append(load(pbrt_ref))
        rows.append(row)
    width = 3 * TILE + 2 * 4
    sheet = np.full((len(rows) * (TILE + 4), width, 3), 255, np.uint8)
    for r, row in enumerate(rows):
        for c, img in enumerate(row):
            y, x = r * (TILE + 4), c * (TILE + 4)
            sheet[y : y + TILE, x : x + TILE] = tile(img)
    Image.fromarray(sheet).save(a.o)
    print(f"wrote {a.o}")


if __name__ == "__main__":
    main()
