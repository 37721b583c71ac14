"""Contact sheet of every scene file under ../shared/scenes/real (docs/real_scenes.png), each
as a user first sees it: `pathtracer FILE` with no flags but the samples and depth, so that a
file without a camera is framed whole and one without lights is lit by the studio light. Run
after ``pip install ./python``::

    python examples/real_scenes_sheet.py [--shared ../shared] [-o docs/real_scenes.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pathtracer as pt

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--shared", default=str(ROOT.parent / "shared"))
    p.add_argument("-o", "--output", default=str(ROOT / "docs/real_scenes.png"))
    p.add_argument("--spp", type=int, default=64)
    a = p.parse_args()
    real = Path(a.shared) / "scenes/real"
    files = sorted(
        f for f in real.rglob("*") if f.suffix in (".obj", ".ply", ".gltf", ".glb")
    )
    # Rendered at the default 480×360 and halved.
    w, h = 240, 180
    tiles = []
    for f in files:
        scene = pt.load(f)
        img = pt.render(scene, spp=a.spp, max_depth=8)
        half = img.reshape(h, 2, w, 2, 3).mean(axis=(1, 3))
        tiles.append(np.clip(half, 0.0, 1.0))
        print(f"{f.relative_to(real)}: rendered", flush=True)
    cols = 4
    rows = -(-len(tiles) // cols)
    sheet = np.zeros((rows * (h + 4), cols * (w + 4), 3), np.float32)
    for i, t in enumerate(tiles):
        y, x = (i // cols) * (h + 4), (i % cols) * (w + 4)
        sheet[y : y + h, x : x + w] = t
    pt.write_image(a.output, sheet)
    print("order (left to right, top to bottom):")
    for f in files:
        print(f"  {f.relative_to(real)}")


if __name__ == "__main__":
    main()
