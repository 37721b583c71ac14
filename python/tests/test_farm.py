"""The Ray farm on local multi-node clusters: the command line's image, bit for bit, also when
a worker node dies mid-render."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT, run_cli

import pathtracer as pt

if os.environ.get("PATHTRACER_REQUIRE_RAY"):
    import ray  # CI: the farm tests must run, not skip
else:
    ray = pytest.importorskip("ray", reason="notice: the farm tests need Ray (pip install ray)")
from ray.cluster_utils import Cluster
from test_denoise import has_oidn

from pathtracer import farm

FLAGS = ["-r", "200", "150", "-s", "48", "-m", "4", "--seed", "7"]


@pytest.fixture
def cluster() -> Iterator[Cluster]:
    """A head node and one worker node, one CPU each, on loopback."""
    c = Cluster(
        initialize_head=True, head_node_args={"num_cpus": 1, "object_store_memory": 150 * 2**20}
    )
    c.add_node(num_cpus=1, object_store_memory=150 * 2**20)
    ray.init(address=c.address)
    c.wait_for_nodes()
    yield c
    ray.shutdown()
    c.shutdown()


def cli_image(cli: Path, tmp: Path, *flags: str) -> np.ndarray:
    r = run_cli(cli, *flags, "-t", "2", "-f", str(tmp / "cli.exr"))
    assert r.returncode == 0, r.stderr
    return pt.read_image(tmp / "cli.exr")


def test_farm_on_two_nodes_equals_the_cli(cluster: Cluster, cli: Path, tmp_path: Path) -> None:
    want = cli_image(cli, tmp_path, *FLAGS)
    a = farm.parse_args([*FLAGS, "--chunks", "6", "-f", str(tmp_path / "farm.exr")])
    r = farm.run(a)
    assert len(r.chunk_nodes) == 6 and len(set(r.chunk_nodes)) == 2
    assert np.array_equal(r.image, want)
    print(f"farm on 2 nodes: {r.seconds:.2f} s, merge {r.merge_seconds:.3f} s")
    # Splitting the frame instead of the samples gives the same image.
    t = farm.run(farm.parse_args([*FLAGS, "--chunks", "5", "--tiles", "-f", "x.exr"]))
    assert np.array_equal(t.image, want)
    # Media: a grid, and water in glass whose volumetric caustics are traced from the light.
    for name in ("media_smoke", "media_glass"):
        scene = str(ROOT / "tests/mitsuba/scenes" / f"{name}.xml")
        flags = ["-s", "12", "--seed", "5", scene]
        want = cli_image(cli, tmp_path, *flags)
        m = farm.run(farm.parse_args([*flags, "--chunks", "3", "-f", str(tmp_path / "m.exr")]))
        assert np.array_equal(m.image, want), name
    # The merged film (or the tiles) denoised: the command line's --denoise image.
    if has_oidn():
        flags = [*FLAGS, "--denoise"]
        want = cli_image(cli, tmp_path, *flags)
        for split in ([], ["--tiles"]):
            d = farm.run(farm.parse_args([*flags, *split, "--chunks", "3", "-f", "d.exr"]))
            assert np.array_equal(d.image, want), split


def test_farm_survives_a_lost_node(cluster: Cluster, cli: Path, tmp_path: Path) -> None:
    want = cli_image(cli, tmp_path, *FLAGS)
    head = ray.get_runtime_context().get_node_id()
    worker = next(n for n in cluster.list_all_nodes() if not n.head)
    killed: list[int] = []

    def kill(done: int, total: int, node: str) -> None:
        # When the head finishes a chunk, the worker node is busy with another: kill it.
        if not killed and node == head:
            cluster.remove_node(worker)
            killed.append(done)

    a = farm.parse_args([*FLAGS, "--chunks", "8", "-f", str(tmp_path / "farm.exr")])
    r = farm.run(a, on_chunk=kill)
    print(f"killed the worker after chunk {killed}; chunks by node: {r.chunk_nodes}")
    assert killed, "the worker node was never killed"
    assert killed[0] < 8 and len(r.chunk_nodes) == 8
    # Every chunk finished after the kill ran on the head.
    assert all(n == head for n in r.chunk_nodes[killed[0] :])
    assert np.array_equal(r.image, want)


def test_farm_command_writes_the_image_and_fails_fast(cli: Path, tmp_path: Path) -> None:
    out = tmp_path / "farm.exr"
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    cmd = [sys.executable, "-m", "pathtracer.farm", *FLAGS, "--chunks", "3", "-f", str(out)]
    r = subprocess.run(
        cmd, capture_output=True, text=True, timeout=300, cwd=ROOT, check=False, env=env
    )
    assert r.returncode == 0, r.stderr
    assert np.array_equal(pt.read_image(out), cli_image(cli, tmp_path, *FLAGS))
    # A scene that cannot load fails at once, with the command line's message, before Ray.
    bad = tmp_path / "bad.ply"
    bad.write_text("ply\nformat ascii 1.0\nelement vertex x\nend_header\n")
    r = subprocess.run(
        [sys.executable, "-m", "pathtracer.farm", str(bad), "-f", str(tmp_path / "no.exr")],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        cwd=ROOT,
        env=env,
    )
    line = run_cli(cli, "--info", str(bad)).stderr.strip().splitlines()[-1]
    assert r.returncode == 2 and r.stderr.strip().splitlines()[-1] == line, r.stderr
    assert "ray" not in r.stderr.lower()
    assert not (tmp_path / "no.exr").exists()


def test_films_of_other_options_do_not_merge(cluster: Cluster, tmp_path: Path) -> None:
    """A farm chunk's film carries the render's identity: a Python film rendered with another
    max_depth is refused, naming it; one with the same options merges."""
    a = farm.parse_args([*FLAGS, "-f", str(tmp_path / "x.exr")])
    job, opts = farm.prepare_job(a)
    task = ray.remote(farm.render_task)
    data, _, _ = ray.get(task.remote(job, dict(opts, sample_range=(0, 24))))
    farm_film = pt.Film.from_bytes(data)
    deeper = pt.render_film(pt.load(), **dict(opts, max_depth=5, sample_range=(24, 24)))
    with pytest.raises(pt.Error, match="max-depth is 4 in this film but 5 in the other"):
        farm_film.merge(deeper)
    farm_film.merge(pt.render_film(pt.load(), **dict(opts, sample_range=(24, 24))))
    assert farm_film.samples == 200 * 150 * 48


@pytest.mark.parametrize(
    "flags",
    [["--time-limit", "5"], ["-a", "16", "0.05"], ["-p", "0", "0", "8", "8"], ["--resume", "x"]],
)
def test_flags_of_one_machines_render_are_refused(
    flags: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as e:
        farm.parse_args([*FLAGS, *flags, "-f", "x.exr"])
    assert e.value.code == 2
    assert "the farm does not take" in capsys.readouterr().err
