"""pbrt-v4 files in Python: `pt.load` reads them, renders take the file's settings (its film's
size, sample count and pixel filter) unless keywords say otherwise, and the image equals the
command line's for the same file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from conftest import ROOT, run_cli

import pathtracer as pt

SCENE = ROOT / "tests/pbrt/scenes/coateddiffuse.pbrt"


def test_pbrt_file_renders_with_its_own_settings(cli: Path, tmp_path: Path) -> None:
    scene = pt.load(SCENE)
    options = dict(pt.resolve_options(scene))
    assert (options["width"], options["height"], options["spp"]) == ("96", "64", "64")
    assert options["max_depth"] == "8" and options["filter"] == "box"
    img = pt.render(scene, spp=4, threads=2)
    assert img.shape == (64, 96, 3) and np.isfinite(img).all() and img.mean() > 0.01
    small = pt.render(scene, spp=4, threads=2, width=48, height=32)
    assert small.shape == (32, 48, 3)
    out = tmp_path / "cli.exr"
    r = run_cli(cli, "-s", "4", "-t", "2", "-f", str(out), str(SCENE))
    assert r.returncode == 0, r.stderr
    assert np.array_equal(pt.read_image(out), img)
