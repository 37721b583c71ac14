"""The Python module against the command line: same bits, same errors, interruptible."""

from __future__ import annotations

import os
import pickle
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import run_cli, shared

import pathtracer as pt

SMALL = {"width": 96, "height": 72, "spp": 8, "max_depth": 3, "seed": 3, "threads": 2}
SMALL_FLAGS = ["-r", "96", "72", "-s", "8", "-m", "3", "--seed", "3", "-t", "2"]


def cli_image(cli: Path, tmp: Path, *args: str) -> np.ndarray:
    out = tmp / "cli.exr"
    r = run_cli(cli, *args, "-f", str(out))
    assert r.returncode == 0, r.stderr
    return pt.read_image(out)


def test_render_equals_cli_bit_for_bit(cli: Path, tmp_path: Path) -> None:
    scene = pt.load()
    img = pt.render(scene, **SMALL)
    assert img.dtype == np.float32 and img.shape == (72, 96, 3)
    assert np.array_equal(img, cli_image(cli, tmp_path, *SMALL_FLAGS))
    # Other options map to the same flags too.
    opts = dict(SMALL, sampler="zsobol", direct="light", light_samples=2, rr_depth=2)
    flags = SMALL_FLAGS + ["--sampler", "zsobol", "--direct", "light", "-l", "2", "--rr-depth", "2"]
    assert np.array_equal(pt.render(scene, **opts), cli_image(cli, tmp_path, *flags))
    # A cell is the cell's part of the frame.
    part = pt.render(scene, **dict(SMALL, cell=(10, 20, 30, 16)))
    assert np.array_equal(part, img[20:36, 10:40])


def test_shared_scene_with_environment_equals_cli(cli: Path, tmp_path: Path) -> None:
    s = shared()
    if s is None:
        return
    scene_file = s / "scenes/cs184/sky/CBbunny.dae"
    env = s / "envmaps/sunrise.exr"
    if not env.exists():
        env = next((s / "envmaps").glob("*.exr"))
    scene = pt.load(scene_file, env=env)
    assert "triangles" in scene.summary and scene.name == "CBbunny"
    assert [Path(f).resolve() for f in scene.files] == [scene_file.resolve(), env.resolve()]
    img = pt.render(scene, **SMALL)
    flags = [str(scene_file), "-e", str(env), *SMALL_FLAGS]
    assert np.array_equal(img, cli_image(cli, tmp_path, *flags))


def test_sample_ranges_merge_to_the_whole(tmp_path: Path) -> None:
    scene = pt.load()
    whole = pt.render(scene, **SMALL)
    films = [pt.render_film(scene, **dict(SMALL, sample_range=r)) for r in [(0, 3), (3, 1), (4, 4)]]
    # Through pickling (as Ray moves them) and through a file.
    films[1] = pickle.loads(pickle.dumps(films[1]))
    films[2].save(tmp_path / "part.film")
    films[2] = pt.Film.load(tmp_path / "part.film")
    merged = films[0]
    merged.merge(films[1])
    merged.merge(films[2])
    assert merged.samples == 96 * 72 * 8
    assert np.array_equal(merged.develop(), whole)
    assert np.array_equal(merged.counts(), np.full((72, 96), 8, np.uint32))
    # A film continued to its target equals the whole render as well.
    film = pt.render_film(scene, **dict(SMALL, sample_range=(0, 8), time_limit=1e-9))
    assert 0 < film.samples < 96 * 72 * 8
    pt.render_film(scene, film, **dict(SMALL, sample_range=(0, 8)))
    assert np.array_equal(film.develop(), whole)
    # A range that is not adjacent is refused.
    with pytest.raises(pt.Error, match="sample"):
        films2 = pt.render_film(scene, **dict(SMALL, sample_range=(4, 4)))
        films2.merge(pt.render_film(scene, **dict(SMALL, sample_range=(0, 3))))


def test_errors_carry_the_command_lines_text(cli: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    missing = tmp_path / "missing.dae"
    for path in [bad, missing]:
        r = run_cli(cli, "--info", str(path))
        assert r.returncode == 2
        line = r.stderr.strip().splitlines()[-1]
        assert line.startswith("error: ")
        with pytest.raises(pt.Error) as e:
            pt.load(path)
        assert str(e.value) == line[len("error: ") :]
    with pytest.raises(pt.Error, match=r"bad\.obj:4"):
        pt.load(bad)
    with pytest.raises(TypeError, match="unknown render option 'spps'"):
        pt.render(pt.load(), spps=4)
    with pytest.raises(ValueError, match="sampler"):
        pt.render(pt.load(), sampler="halton")
    with pytest.raises(pt.Error, match="sample_range"):
        pt.render(pt.load(), spp=4, sample_range=(2, 3))


def test_keyboard_interrupt_within_a_second() -> None:
    # Python raises KeyboardInterrupt only where SIGINT has its default handler; a process
    # started in the background by a non-interactive shell inherits SIGINT ignored (POSIX),
    # and the signal would then be lost. So the handler is installed for this test. The time
    # limit bounds the render if the interrupt does not stop it.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    scene = pt.load()
    sent: list[float] = []

    def interrupt() -> None:
        time.sleep(0.5)
        sent.append(time.monotonic())
        os.kill(os.getpid(), signal.SIGINT)

    threading.Thread(target=interrupt, daemon=True).start()
    try:
        with pytest.raises(KeyboardInterrupt):
            pt.render(scene, spp=100000, max_depth=50, threads=2, time_limit=60.0)
    finally:
        signal.signal(signal.SIGINT, previous)
    delay = time.monotonic() - sent[0]
    assert delay < 1.0, f"KeyboardInterrupt {delay:.2f} s after SIGINT"


def test_camera_setter_moves_the_view(cli: Path, tmp_path: Path) -> None:
    scene = pt.load()
    before = pt.render(scene, **SMALL)
    cam = scene.camera
    assert cam.fov is None and cam.lens_radius == 0.0
    cam.position = (0.3, 1.2, 3.0)
    cam.target = (0.0, 0.9, 0.0)
    cam.up = (0.0, 1.0, 0.0)
    cam.fov = 50.0
    scene.camera = cam
    assert np.allclose(scene.camera.position, (0.3, 1.2, 3.0))
    assert abs(scene.camera.field_of_view(72) - 50.0) < 1e-3
    moved = pt.render(scene, **SMALL)
    assert not np.array_equal(moved, before)
    flags = [
        *SMALL_FLAGS,
        "--lookat",
        "0.3",
        "1.2",
        "3.0",
        "0",
        "0.9",
        "0",
        "0",
        "1",
        "0",
        "--fov",
        "50",
    ]
    assert np.array_equal(moved, cli_image(cli, tmp_path, *flags))
    # A lens, as -b and -d.
    cam.lens_radius, cam.focal_distance = 0.05, 2.5
    scene.camera = cam
    lens = pt.render(scene, **SMALL)
    assert np.array_equal(lens, cli_image(cli, tmp_path, *flags, "-b", "0.05", "-d", "2.5"))
    # A camera made from scratch; bad cameras are refused and change nothing.
    scene.camera = pt.Camera((0.0, 1.0, 4.0), (0.0, 1.0, 0.0), fov=40.0)
    with pytest.raises(ValueError):
        pt.Camera((0.0, 1.0, 0.0), (0.0, 1.0, 0.0))
    with pytest.raises(ValueError):
        cam.fov = 190.0
    assert cam.fov == 50.0


def test_aux_images() -> None:
    scene = pt.load()
    a = pt.aux(scene, **SMALL)
    assert set(a) == {"albedo", "normal", "depth"}
    for v in a.values():
        assert v.shape == (72, 96, 3) and v.dtype == np.float32 and np.isfinite(v).all()
    centre = (36, 48)
    assert a["depth"][centre][0] > 0
    assert abs(np.linalg.norm(a["normal"][centre]) - 1.0) < 1e-3
    assert 0.0 <= a["albedo"].min() and a["albedo"].max() <= 1.0


def test_write_and_read_images(tmp_path: Path) -> None:
    img = pt.render(pt.load(), **SMALL)
    pt.write_image(tmp_path / "a.exr", img)
    assert np.array_equal(pt.read_image(tmp_path / "a.exr"), img)
    pt.write_image(tmp_path / "a.png", img.astype(np.float64))
    png = pt.read_image(tmp_path / "a.png")
    assert png.shape == img.shape and np.abs(png - np.clip(img, 0, 1)).max() < 0.02
    bad = img.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="not finite"):
        pt.write_image(tmp_path / "b.exr", bad)
    assert not (tmp_path / "b.exr").exists()
    with pytest.raises(pt.Error, match="unsupported|format"):
        pt.write_image(tmp_path / "a.jpg", img)


def test_the_readme_example_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    s = shared()
    if s is None:
        return
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    code = readme.split("```python\n", 1)[1].split("```", 1)[0]
    assert len(code.strip().splitlines()) <= 12
    monkeypatch.chdir(tmp_path)
    # The README's own example, run as written (trusted text of this repository).
    exec(compile(code.replace("../shared", str(s)), "README.md", "exec"), {})  # noqa: S102
    assert (tmp_path / "bunny.exr").exists()


def test_a_light_less_model_is_framed_and_lit_as_the_command_line_does(
    cli: Path, tmp_path: Path
) -> None:
    """A PLY without lights or a camera: the studio light and the framing for the size asked,
    bit for bit as the command line; `no_default_light=True` leaves it black; a bad value is
    refused naming the option (issue 39)."""
    ply = tmp_path / "tetra.ply"
    ply.write_text(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
        "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"
    )
    scene = pt.load(ply)
    assert any("studio light" in n for n in scene.notes), scene.notes
    img = pt.render(scene, **SMALL)
    assert img.mean() > 0.1
    assert np.array_equal(img, cli_image(cli, tmp_path, *SMALL_FLAGS, str(ply)))
    dark = pt.load(ply, no_default_light=True)
    assert dark.notes == [] and any("black" in w for w in dark.warnings)
    assert pt.render(dark, **SMALL).max() == 0.0
    with pytest.raises(pt.OptionError, match="no_default_light"):
        pt.load(ply, no_default_light="lots")
