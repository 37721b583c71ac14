"""Mitsuba 3 XML files in Python: `pt.load` reads them (with `defines` for their `$name`
parameters), renders take the file's settings unless keywords say otherwise, and the image
equals the command line's for the same file and parameters."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT, run_cli

import pathtracer as pt

SCENE = ROOT / "tests/mitsuba/scenes/plastics.xml"


def test_mitsuba_file_renders_with_its_own_settings(cli: Path, tmp_path: Path) -> None:
    scene = pt.load(SCENE, defines={"spp": "3"})
    options = dict(pt.resolve_options(scene))
    assert (options["width"], options["height"], options["spp"]) == ("64", "64", "3")
    assert options["max_depth"] == "5" and options["filter"] == "box"
    img = pt.render(scene, threads=2)
    assert img.shape == (64, 64, 3) and np.isfinite(img).all() and img.mean() > 0.01
    out = tmp_path / "cli.exr"
    r = run_cli(cli, "-t", "2", "-D", "spp=3", "-f", str(out), str(SCENE))
    assert r.returncode == 0, r.stderr
    assert np.array_equal(pt.read_image(out), img)


@pytest.mark.parametrize("name", ["media_glass", "media_smoke"])
def test_media_render_as_on_the_command_line(name: str, cli: Path, tmp_path: Path) -> None:
    """Participating media (water in glass with its volumetric caustics traced from the light;
    a grid) render in Python as the command line renders them, bit for bit."""
    scene_file = ROOT / "tests/mitsuba/scenes" / f"{name}.xml"
    img = pt.render(pt.load(scene_file), spp=8, threads=2, seed=3)
    assert np.isfinite(img).all() and img.mean() > 0.01
    out = tmp_path / "cli.exr"
    r = run_cli(cli, "-s", "8", "-t", "2", "--seed", "3", "-f", str(out), str(scene_file))
    assert r.returncode == 0, r.stderr
    assert np.array_equal(pt.read_image(out), img)


def test_a_bad_mitsuba_file_names_its_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.xml"
    bad.write_text(
        '<scene version="3.0.0">\n<shape type="sphere"><ref id="nothing"/></shape>\n</scene>\n'
    )
    with pytest.raises(pt.Error, match=r"bad\.xml:2:.*no object has id \"nothing\""):
        pt.load(bad)
