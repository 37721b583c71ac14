"""Contact sheet of pbrt-v4 or Mitsuba 3 scenes beside their own renderer's images
(docs/pbrt_scenes.png, docs/mitsuba_scenes.png).

Each pair is this renderer (left) and the format's own renderer (right): Bitterli's scenes
(``../shared/refs/pbrt-v4``: veach-mis and coffee; ``../shared/refs/mitsuba``: cornell-box and
classroom), then the project's own test scenes (``tests/pbrt``, ``tests/mitsuba``), each at its
reference's size and with the file's own settings but the sample count. Run after
``pip install ./python``::

    python examples/reference_sheet.py [--format pbrt|mitsuba] [--shared ../shared] [--spp 256]
                                       [-o docs/FORMAT_scenes.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pathtracer as pt

ROOT = Path(__file__).resolve().parents[1]
TILE_H = 128


def fit(img: np.ndarray) -> np.ndarray:
    """`img` scaled to TILE_H rows (nearest rows and columns), sRGB-clamped later."""
    h, w, _ = img.shape
    ys = (np.arange(TILE_H) * h / TILE_H).astype(int)
    width = max(1, round(w * TILE_H / h))
    xs = (np.arange(width) * w / width).astype(int)
    return img[ys][:, xs]


def scene_pairs(fmt: str, shared: Path) -> list[tuple[str, Path, Path]]:
    """(name, scene file, reference image) of the shared scenes, then of the test scenes."""
    if fmt == "pbrt":
        names, scene, ref, ext = (
            ("veach-mis", "coffee"),
            "scenes/pbrt-v4/{}/scene-v4.pbrt",
            "refs/pbrt-v4/{}.exr",
            "pbrt",
        )
    else:
        names, scene, ref, ext = (
            ("cornell-box", "classroom"),
            "scenes/mitsuba/{}/scene_v3.xml",
            "refs/mitsuba/{}.exr",
            "xml",
        )
    pairs = [(n, shared / scene.format(n), shared / ref.format(n)) for n in names]
    tests = ROOT / "tests" / fmt
    pairs += [
        (f.stem, f, tests / "refs" / f"{f.stem}.exr")
        for f in sorted((tests / "scenes").glob(f"*.{ext}"))
    ]
    return pairs


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--shared", default=str(ROOT.parent / "shared"))
    p.add_argument("--format", choices=["pbrt", "mitsuba"], default="pbrt")
    p.add_argument("-o", "--output", default=None)
    p.add_argument("--spp", type=int, default=256)
    a = p.parse_args()
    output = a.output or str(ROOT / f"docs/{a.format}_scenes.png")
    pairs = scene_pairs(a.format, Path(a.shared))
    rows: list[np.ndarray] = []
    row: list[np.ndarray] = []
    width = 0
    for name, scene_file, ref_file in pairs:
        ref = pt.read_image(ref_file)
        h, w, _ = ref.shape
        scene = pt.load(scene_file)
        if dict(pt.resolve_options(scene))["cell"] == "none":
            ours = pt.render(scene, spp=a.spp, width=w, height=h)
        else:  # a crop window: the file's own frame and cell (the reference's size)
            ours = pt.render(scene, spp=a.spp)
        pair = np.concatenate(
            [fit(ours), np.ones((TILE_H, 2, 3), np.float32), fit(ref)], 1
        )
        print(f"{name}: rendered {w}x{h}", flush=True)
        if width + pair.shape[1] > 1400 and row:
            rows.append(np.concatenate(row, 1))
            row, width = [], 0
        row += [pair, np.zeros((TILE_H, 8, 3), np.float32)]
        width += pair.shape[1] + 8
    rows.append(np.concatenate(row, 1))
    full = max(r.shape[1] for r in rows)
    padded = [np.pad(r, ((0, 8), (0, full - r.shape[1]), (0, 0))) for r in rows]
    pt.write_image(output, np.clip(np.concatenate(padded, 0), 0.0, 1.0))


if __name__ == "__main__":
    main()
