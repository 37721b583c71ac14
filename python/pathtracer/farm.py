"""One image over many machines: ``python -m pathtracer.farm SCENE [render flags] -s N
--chunks K [--address ADDR] -f OUT``.

The driver loads the scene itself first (a scene that fails to load fails here, at once, with
the command line's message), then puts the bytes of every file the scene was read from (the
scene file, its MTL files or glTF buffers, the environment map, the camera file) into Ray's
object store once. K tasks each render a disjoint range of the N samples per pixel into a
film; a worker process unpacks the files and loads the scene on its first task and keeps it
for the next ones. The driver merges the films in chunk order, and the sums are exact
integers, so the image is bit-identical to ``pathtracer -s N`` with the same seed and flags
whatever the number of nodes and the order in which tasks finish. A task lost with its node
is run again elsewhere (Ray's ``max_retries``) and gives the same bits. ``--tiles`` splits the
frame into K bands of rows instead of splitting the samples.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import Any, Callable

import numpy as np

import pathtracer as pt

# A worker process's scene, loaded on its first task: (bundle digest, scene).
_SCENE: tuple[str, pt.Scene] | None = None


@dataclass
class Job:
    """What every task of one farm render needs besides its own range or band."""

    bundle: list[Any]  # [ObjectRef of {relative path: bytes}], in a list so Ray passes the ref
    digest: str
    scene: str | None  # relative path of the scene file in the bundle; None: built-in
    env: str | None
    env_sampling: str
    no_default_light: bool
    camera_file: str | None


# Render options of one machine's render, which the farm refuses.
SINGLE_MACHINE = ("time_limit", "adaptive", "adaptive_budget", "cell", "threads")


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The farm's own flags, and its render flags parsed by the command line's parser
    (`pathtracer.parse_args`): the same flags, defaults and checks as `pathtracer`."""
    p = argparse.ArgumentParser(
        prog="python -m pathtracer.farm",
        description="Render one image on a Ray cluster, bit-identical to `pathtracer -s N`. "
        "Every render flag is the command line's (see `pathtracer --help`); -f FILE is the "
        "output image.",
    )
    p.add_argument("--chunks", type=int, default=8, help="tasks to split the render into")
    p.add_argument("--address", help="Ray cluster address (default: start a local one)")
    p.add_argument("--tiles", action="store_true", help="split the frame, not the samples")
    p.add_argument("--cpus-per-task", type=int, default=1, help="CPUs (threads) per task")
    p.add_argument("--max-retries", type=int, default=3, help="reruns of a task lost with its node")
    a, rest = p.parse_known_args(argv)
    if a.chunks < 1 or a.cpus_per_task < 1 or a.max_retries < 0:
        p.error("--chunks and --cpus-per-task must be positive, --max-retries ≥ 0")
    try:
        parsed = pt.parse_args(rest)
    except pt.Error as e:
        p.error(str(e).removeprefix("error: "))
    # What a split render cannot do: time-limited or adaptive chunks would not add up to one
    # render, cells are --tiles' own, and the command line's files are its own.
    cannot = [f"--{k.replace('_', '-')}" for k in SINGLE_MACHINE if k in parsed["options"]]
    cannot += parsed["other_flags"]
    if cannot:
        p.error(f"the farm does not take {', '.join(cannot)} (a command-line render does)")
    if parsed["output"] is None:
        p.error("the output image is required: -f FILE (.exr or .png)")
    for key in (
        "scene",
        "output",
        "env",
        "camera_file",
        "env_sampling",
        "no_default_light",
        "options",
    ):
        setattr(a, key, parsed[key])
    a.output = str(a.output)
    if Path(a.output).suffix.lower() not in (".exr", ".png"):
        p.error(f"{a.output}: unsupported output format (use .png or .exr)")
    return a


def render_options(scene: pt.Scene, a: argparse.Namespace) -> dict[str, Any]:
    """The render keywords of the flags (as `pathtracer.render` takes them), with the
    resolved `spp`, `width` and `height` the farm splits the render by."""
    opts = dict(a.options)
    resolved = dict(pt.resolve_options(scene, **opts))
    for key in ("spp", "width", "height"):
        opts[key] = int(resolved[key])
    return opts


def bundle(paths: Sequence[os.PathLike[str] | str]) -> tuple[dict[str, bytes], dict[str, str]]:
    """The files `paths` as {path relative to their common folder: bytes}, and the relative
    name of each file's resolved path."""
    full = [Path(p).resolve() for p in paths]
    if not full:
        return {}, {}
    root = Path(os.path.commonpath([str(p.parent) for p in full]))
    files = {p.relative_to(root).as_posix(): p.read_bytes() for p in full}
    names = {str(f): f.relative_to(root).as_posix() for f in full}
    return files, names


def digest_of(files: dict[str, bytes]) -> str:
    """SHA-256 over the bundle's names and contents."""
    h = hashlib.sha256()
    for name in sorted(files):
        h.update(name.encode() + b"\0" + len(files[name]).to_bytes(8, "little"))
        h.update(files[name])
    return h.hexdigest()


def _unpack(files: dict[str, bytes]) -> Path:
    """Writes the bundle into a new temporary folder (names are checked: relative, no '..')."""
    root = Path(tempfile.mkdtemp(prefix="pathtracer-farm-"))
    for name, data in files.items():
        rel = PurePosixPath(name)
        if rel.is_absolute() or ".." in rel.parts:
            raise ValueError(f"bundle entry {name!r} leaves its folder")
        dest = root.joinpath(*rel.parts)
        dest.parent.mkdir(parents=True, exist_ok=True)
        dest.write_bytes(data)
    return root


def worker_scene(job: Job) -> pt.Scene:
    """The job's scene in this worker process: loaded from the bundle on the first task, kept
    for the next ones."""
    global _SCENE
    if _SCENE is not None and _SCENE[0] == job.digest:
        return _SCENE[1]
    import ray

    files = ray.get(job.bundle[0])
    root = _unpack(files)
    at = lambda rel: None if rel is None else str(root / rel)
    scene = pt.load(
        at(job.scene),
        env=at(job.env),
        env_sampling=job.env_sampling,
        camera_file=at(job.camera_file),
        no_default_light=job.no_default_light,
    )
    _SCENE = (job.digest, scene)
    return scene


def render_task(job: Job, opts: dict[str, Any]) -> tuple[bytes, str, float]:
    """One chunk: its film's bytes, the id of the node that rendered it, and the seconds the
    task took in the worker (scene loading on a worker's first task included)."""
    import ray

    t = time.monotonic()
    film = pt.render_film(worker_scene(job), **opts)
    data = film.to_bytes()
    return data, ray.get_runtime_context().get_node_id(), time.monotonic() - t


def sample_ranges(spp: int, chunks: int) -> list[tuple[int, int]]:
    """`[0, spp)` in `chunks` contiguous ranges (first, count) as equal as can be."""
    k = min(chunks, spp)
    return [(i * spp // k, (i + 1) * spp // k - i * spp // k) for i in range(k)]


def row_bands(height: int, chunks: int) -> list[tuple[int, int]]:
    """`[0, height)` in contiguous bands (y, rows)."""
    return sample_ranges(height, chunks)


class Progress:
    """A bar of finished chunks on stderr (plain lines when stderr is not a terminal)."""

    def __init__(self, total: int) -> None:
        self.total, self.start = total, time.monotonic()
        self.tty = sys.stderr.isatty()

    def update(self, done: int) -> None:
        t = time.monotonic() - self.start
        eta = t / done * (self.total - done) if done else float("nan")
        if self.tty:
            n = 30 * done // self.total
            sys.stderr.write(
                f"\r[{'#' * n}{'.' * (30 - n)}] {done}/{self.total} chunks, "
                f"{t:.1f} s, ETA {eta:.1f} s"
            )
            if done == self.total:
                sys.stderr.write("\n")
        else:
            sys.stderr.write(f"farm: {done}/{self.total} chunks after {t:.1f} s\n")
        sys.stderr.flush()


@dataclass
class Result:
    """What a farm render produced and how."""

    image: np.ndarray
    seconds: float
    chunk_nodes: list[str]  # the node that rendered each chunk, in order of completion
    chunk_seconds: list[float]  # each chunk's time in its worker, in order of completion
    merge_seconds: float
    bytes_in: int  # film bytes the driver received


def prepare_job(a: argparse.Namespace) -> tuple[Job, dict[str, Any]]:
    """Loads the scene in the driver (a scene that fails to load fails here, with the command
    line's message), puts its files into Ray's object store (starting Ray, or joining
    `a.address`, first) and returns the job every task shares with the render keywords."""
    import ray

    scene = pt.load(
        a.scene,
        env=a.env,
        env_sampling=a.env_sampling,
        camera_file=a.camera_file,
        no_default_light=a.no_default_light,
    )
    for w in scene.warnings:
        print(f"warning: {w}", file=sys.stderr)
    opts = render_options(scene, a)
    files, names = bundle([str(f) for f in scene.files])

    def name(p: str | os.PathLike[str] | None) -> str | None:
        return None if p is None else names[str(Path(p).resolve())]

    if not ray.is_initialized():
        ray.init(
            address=a.address, include_dashboard=False, log_to_driver=True, configure_logging=False
        )
    job = Job(
        bundle=[ray.put(files)],
        digest=digest_of(files),
        scene=name(a.scene),
        env=name(a.env),
        env_sampling=a.env_sampling,
        no_default_light=a.no_default_light,
        camera_file=name(a.camera_file),
    )
    return job, opts


def run(a: argparse.Namespace, on_chunk: Callable[[int, int, str], None] | None = None) -> Result:
    """Renders the image the flags describe on the Ray cluster (`ray.init` first, or
    `a.address`). `on_chunk(done, total, node_id)` is called in the driver as chunks finish."""
    import ray

    start = time.monotonic()
    job, opts = prepare_job(a)
    if opts.get("denoise"):
        # Open Image Denoise is found before any chunk renders (raises `pt.Error` otherwise).
        pt.denoise(np.zeros((1, 1, 3), np.float32))
    task = ray.remote(render_task).options(num_cpus=a.cpus_per_task, max_retries=a.max_retries)
    w, h = opts["width"], opts["height"]
    if a.tiles:
        parts = [dict(opts, cell=(0, y, w, n)) for y, n in row_bands(h, a.chunks)]
    else:
        parts = [dict(opts, sample_range=r) for r in sample_ranges(opts["spp"], a.chunks)]
    refs = [task.remote(job, dict(p, threads=a.cpus_per_task)) for p in parts]
    index = {r: i for i, r in enumerate(refs)}
    got: dict[int, pt.Film] = {}
    nodes: list[str] = []
    chunk_s: list[float] = []
    progress = Progress(len(refs))
    merged: pt.Film | None = None
    image = np.zeros((h, w, 3), np.float32)
    # Denoising features of the tiles, where the render records them.
    features = {k: np.zeros((h, w, 3), np.float32) for k in ("albedo", "normal")}
    merge_s, bytes_in, nxt = 0.0, 0, 0
    pending = list(refs)
    while pending:
        ready, pending = ray.wait(pending, num_returns=1)
        for r in ready:
            try:
                data, node, secs = ray.get(r)
            except ray.exceptions.RayTaskError as e:
                cause = getattr(e, "cause", None)
                raise pt.Error(str(cause) if cause is not None else str(e)) from None
            bytes_in += len(data)
            nodes.append(node)
            chunk_s.append(secs)
            t0 = time.monotonic()
            got[index[r]] = pt.Film.from_bytes(data)
            # Merge in chunk order, as soon as the next chunk is there.
            while nxt in got:
                f = got.pop(nxt)
                if a.tiles:
                    _, y, _, n = f.cell
                    image[y : y + n] = f.develop()
                    for k, v in (f.features() or {}).items():
                        features[k][y : y + n] = v
                elif merged is None:
                    merged = f
                else:
                    merged.merge(f)
                nxt += 1
            merge_s += time.monotonic() - t0
            progress.update(len(nodes))
            if on_chunk is not None:
                on_chunk(len(nodes), len(refs), node)
    if not a.tiles and merged is not None:
        image = merged.develop()
        features = merged.features() or features
    if opts.get("denoise"):
        image = pt.denoise(image, features["albedo"], features["normal"])
    return Result(
        image=image,
        seconds=time.monotonic() - start,
        chunk_nodes=nodes,
        chunk_seconds=chunk_s,
        merge_seconds=merge_s,
        bytes_in=bytes_in,
    )


def main(argv: Sequence[str] | None = None) -> int:
    """The command: renders, writes the output, prints the figures; 2 on an error."""
    a = parse_args(argv)
    try:
        r = run(a)
        pt.write_image(a.output, r.image)
    except pt.Error as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(
        f"farm: {len(r.chunk_nodes)} chunks on {len(set(r.chunk_nodes))} nodes in "
        f"{r.seconds:.2f} s (merging {r.merge_seconds:.3f} s, {r.bytes_in / 1e6:.1f} MB "
        f"of films received); wrote {a.output}",
        file=sys.stderr,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
