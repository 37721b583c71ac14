"""The Ray farm's overhead against the command line on the same cores.

Renders CBbunny (``-t 2 -s 256 -m 100``, 480×360) once with the command line and then with
``pathtracer.farm`` on local Ray clusters of 1, 2 and 3 nodes sharing this machine's cores,
checks that every farm image equals the command line's bit for bit, and prints a table and
the per-chunk figures an estimate for many machines needs. Run after ``pip install
./python[farm]``::

    python benches/farm_scaling.py [--shared ../shared] [--spp 256] [--chunks-per-cpu 2]
        [--repeat 3]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import pathtracer as pt
import ray
from pathtracer import farm
from ray.cluster_utils import Cluster

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--shared", default=str(ROOT.parent / "shared"))
    p.add_argument("--spp", type=int, default=256)
    p.add_argument("--depth", type=int, default=100)
    p.add_argument("--chunks-per-cpu", type=int, default=2)
    p.add_argument("--repeat", type=int, default=3)
    a = p.parse_args()
    scene = Path(a.shared) / "scenes/cs184/sky/CBbunny.dae"
    flags = [str(scene), "-s", str(a.spp), "-m", str(a.depth)]
    tmp = Path(tempfile.mkdtemp())
    exe = ROOT / "target/release/pathtracer"

    def cli() -> float:
        t = time.monotonic()
        subprocess.run(
            [str(exe), *flags, "-t", "2", "-f", str(tmp / "cli.exr")],
            check=True,
            capture_output=True,
        )
        return time.monotonic() - t

    cli()
    want = pt.read_image(tmp / "cli.exr")
    # (label, head CPUs, worker nodes' CPUs)
    configs = [
        ("1 node × 2 CPUs", 2, []),
        ("2 nodes × 1 CPU", 1, [1]),
        ("3 nodes: head 0 CPUs + 2 × 1 CPU", 0, [1, 1]),
        ("3 nodes × 1 CPU (3 tasks on 2 cores)", 1, [1, 1]),
    ]
    rows = []
    for label, head, workers in configs:
        c = Cluster(initialize_head=True, head_node_args={"num_cpus": head})
        for n in workers:
            c.add_node(num_cpus=n)
        ray.init(address=c.address)
        c.wait_for_nodes()
        cpus = head + sum(workers)
        # Warm-up: starts the worker processes and loads the scene in each.
        farm.run(farm.parse_args([flags[0], "-s", "8", "--chunks", "8", "-f", "w.exr"]))
        args = farm.parse_args(
            [*flags, "--chunks", str(a.chunks_per_cpu * cpus), "-f", "x.exr"]
        )
        cli_s, farm_s, runs = [], [], []
        for _ in range(a.repeat):  # alternated, so that the machine's drift hits both
            cli_s.append(cli())
            r = farm.run(args)
            farm_s.append(r.seconds)
            runs.append(r)
            assert np.array_equal(r.image, want), f"{label}: the farm's image differs"
        c_med, f_med = statistics.median(cli_s), statistics.median(farm_s)
        rows.append((label, c_med, f_med, runs[-1]))
        print(
            f"{label}: CLI {cli_s}, farm {farm_s}: {100 * (f_med / c_med - 1):+.1f}%",
            flush=True,
        )
        ray.shutdown()
        c.shutdown()
    print()
    print(
        f"CBbunny, {' '.join(flags[1:])}, 480×360; medians of {a.repeat} alternated runs; "
        "every farm image bit-identical to the CLI's"
    )
    print()
    print(
        "| cluster | chunks | CLI -t 2 s | farm s | farm vs CLI | chunk s (median) | "
        "driver decode+merge s | MB received |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for label, c_med, f_med, r in rows:
        print(
            f"| {label} | {len(r.chunk_seconds)} | {c_med:.2f} | {f_med:.2f} | "
            f"{100 * (f_med / c_med - 1):+.1f}% | {statistics.median(r.chunk_seconds):.2f} | "
            f"{r.merge_seconds:.3f} | {r.bytes_in / 1e6:.1f} |"
        )
    r = rows[0][3]
    per_chunk = r.bytes_in / len(r.chunk_seconds)
    print()
    print(
        f"film bytes per chunk: {per_chunk / 1e6:.2f} MB; driver decode + merge per chunk "
        f"{r.merge_seconds / len(r.chunk_seconds) * 1e3:.1f} ms; sample cost "
        f"{2 * rows[0][1] / (a.spp * 480 * 360) * 1e6:.3f} core-µs per sample (CLI, 2 cores)"
    )


if __name__ == "__main__":
    main()
