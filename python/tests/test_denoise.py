"""Denoising from Python: `render(denoise=True)` and the farm give the command line's
`--denoise` image, `pt.denoise` works on arrays, and a film carries its features. The tests
that run the denoiser skip with a notice where Open Image Denoise is not installed (CI
installs `pyoidn` and sets PATHTRACER_REQUIRE_OIDN)."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import numpy as np
import pytest
from conftest import run_cli

import pathtracer as pt

SMALL = {"width": 96, "height": 72, "spp": 8, "max_depth": 3, "seed": 3, "threads": 2}
SMALL_FLAGS = ["-r", "96", "72", "-s", "8", "-m", "3", "--seed", "3", "-t", "2"]


def has_oidn() -> bool:
    """Whether the denoiser loads; a failure where PATHTRACER_REQUIRE_OIDN is set. The
    command line run by the tests is pointed at the `pyoidn` this interpreter imports (the
    module finds it itself; the command line looks in the active environment)."""
    spec = importlib.util.find_spec("pyoidn")
    if spec is not None and spec.origin and "PATHTRACER_OIDN" not in os.environ:
        os.environ["PATHTRACER_OIDN"] = str(Path(spec.origin).parent / "oidn" / "lib")
    try:
        pt.denoise(np.zeros((1, 1, 3), np.float32))
    except pt.Error as e:
        if os.environ.get("PATHTRACER_REQUIRE_OIDN"):
            raise
        print(f"notice: Open Image Denoise is not installed; skipping ({e})")
        return False
    return True


def test_films_carry_their_features() -> None:
    scene = pt.load()
    film = pt.render_film(scene, features=True, **SMALL)
    f = film.features()
    assert f is not None and set(f) == {"albedo", "normal"}
    assert f["albedo"].shape == (72, 96, 3) and f["albedo"].dtype == np.float32
    assert 0.0 <= f["albedo"].min() and f["albedo"].max() <= 1.0
    lengths = np.linalg.norm(f["normal"], axis=2)
    assert lengths.max() <= 1.0 + 1e-5 and np.median(lengths) > 0.99
    # Pickled and merged, they stay.
    back = pt.Film.from_bytes(film.to_bytes())
    assert np.array_equal(back.features()["albedo"], f["albedo"])
    assert pt.render_film(scene, **SMALL).features() is None
    # Features do not change the image.
    assert np.array_equal(film.develop(), pt.render(scene, **SMALL))


def test_render_denoise_equals_the_cli(cli: Path, tmp_path: Path) -> None:
    if not has_oidn():
        return
    scene = pt.load()
    img = pt.render(scene, denoise=True, **SMALL)
    assert np.isfinite(img).all()
    out = tmp_path / "cli.exr"
    r = run_cli(cli, *SMALL_FLAGS, "--denoise", "-f", str(out))
    assert r.returncode == 0, r.stderr
    assert np.array_equal(img, pt.read_image(out))
    assert np.array_equal(pt.read_image(tmp_path / "cli_noisy.exr"), pt.render(scene, **SMALL))


def test_denoise_on_arrays() -> None:
    if not has_oidn():
        return
    scene = pt.load()
    film = pt.render_film(scene, features=True, **SMALL)
    noisy = film.develop()
    f = film.features()
    assert f is not None
    full = pt.denoise(noisy, f["albedo"], f["normal"])
    plain = pt.denoise(noisy)
    assert full.shape == noisy.shape and np.isfinite(full).all() and np.isfinite(plain).all()
    assert not np.array_equal(full, plain)
    # Extreme and non-finite inputs still give a finite image.
    wild = noisy.copy()
    wild[0, 0] = np.nan
    wild[0, 1] = np.inf
    wild[1, 0] = 1e5
    assert np.isfinite(pt.denoise(wild, f["albedo"], f["normal"])).all()
    with pytest.raises(ValueError, match="matching the image"):
        pt.denoise(noisy, f["albedo"][:10])
    with pytest.raises(ValueError, match="needs an albedo"):
        pt.denoise(noisy, normal=f["normal"])
