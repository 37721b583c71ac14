#!/usr/bin/env python3
"""Compare `pathtracer bench` with Intel Embree on the same triangles and ray sets.

Optional, not part of the test suite, and installs nothing by itself. Needs NumPy and
`embreex` (`pip install embreex`). For each scene it runs

    pathtracer bench SCENE -t 1 --npy DIR        (or --synthetic N)

which prints the project's figures and writes the triangles and its ray sets (1024x1024
coherent pinhole rays, 2,000,000 incoherent rays, and the bounce and shadow rays that start on
the surfaces the scene's own view sees, with their t_max) as .npy files. It then builds the same
triangles in Embree and times the same rays with Embree's single-ray queries (rtcIntersect1 /
rtcOccluded1, one thread), then prints project/Embree for every figure from one run, so that
machine noise cancels. For the build, the ratio is Embree/project (above 1: the project
builds faster).

Each side times every figure as the best of three passes. With `--rounds K` the two sides
are measured K times, alternately (project, Embree, project, ...), and each figure is the
best of all rounds on each side: a burst of load on a shared machine that spoils one side's
passes in one round then no longer decides a ratio.

Usage:
    python3 benches/compare_embree.py [--pathtracer target/release/pathtracer] [--rounds K]
                                      [--synthetic N ...] [SCENE.dae ...]
"""

import argparse
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

try:
    from embreex import rtcore_scene as rtcs
    from embreex.mesh_construction import TriangleMesh
except ImportError:
    sys.exit("embreex is not installed: pip install embreex")

FIGURES = [
    "coherent closest-hit",
    "coherent any-hit",
    "incoherent closest-hit",
    "incoherent any-hit",
    "bounce closest-hit",
    "shadow any-hit",
]


def project(binary, target, synthetic, npy):
    args = [binary, "bench", "-t", "1", "--npy", str(npy)]
    args += ["--synthetic", str(synthetic)] if synthetic else [target]
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
    build = float(re.search(r"BVH build: ([0-9.]+) ms", out).group(1))
    figures = {}
    for name in FIGURES:
        m = re.search(re.escape(name) + r"\s+([0-9.]+) Mr/s", out)
        figures[name] = float(m.group(1))
    name = re.search(r"scene (\S+):", out).group(1)
    return name, build, figures


def best_of(n, f):
    best = float("inf")
    for _ in range(n):
        t = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t)
    return best


def embree(npy):
    tris = np.load(npy / "triangles.npy").reshape(-1, 3, 3).astype(np.float32)

    def build():
        scene = rtcs.EmbreeScene()
        TriangleMesh(scene, tris)
        # The BVH is built at the first query: include one.
        scene.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32))
        return scene

    build_s = best_of(3, build)
    scene = build()
    figures = {}
    for figure in FIGURES:
        kind, label = figure.split()
        o = np.ascontiguousarray(np.load(npy / f"{kind}_origins.npy"), dtype=np.float32)
        d = np.ascontiguousarray(
            np.load(npy / f"{kind}_directions.npy"), dtype=np.float32
        )
        t = np.ascontiguousarray(
            np.load(npy / f"{kind}_tmax.npy").reshape(-1), dtype=np.float32
        )
        query = "INTERSECT" if label == "closest-hit" else "OCCLUDED"
        s = best_of(3, lambda o=o, d=d, t=t, q=query: scene.run(o, d, dists=t, query=q))
        figures[figure] = len(o) / s / 1e6
    return build_s * 1e3, figures


def main():
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument(
        "scenes", nargs="*", help="scene files (any format the renderer reads)"
    )
    ap.add_argument(
        "--synthetic",
        type=int,
        action="append",
        default=[],
        help="synthetic mesh of about N triangles",
    )
    ap.add_argument("--pathtracer", default="target/release/pathtracer")
    ap.add_argument(
        "--rounds",
        type=int,
        default=1,
        help="measure both sides K times, alternately; keep the best",
    )
    a = ap.parse_args()
    targets = [(s, None) for s in a.scenes] + [(None, n) for n in a.synthetic]
    if not targets:
        ap.error("give at least one scene or --synthetic N")
    rows = []
    for scene, n in targets:
        p_build = e_build = float("inf")
        p = {f: 0.0 for f in FIGURES}
        e = dict(p)
        with tempfile.TemporaryDirectory() as tmp:
            npy = Path(tmp)
            for _ in range(max(a.rounds, 1)):
                name, pb, pf = project(a.pathtracer, scene, n, npy)
                eb, ef = embree(npy)
                p_build, e_build = min(p_build, pb), min(e_build, eb)
                p = {f: max(p[f], pf[f]) for f in FIGURES}
                e = {f: max(e[f], ef[f]) for f in FIGURES}
        if scene:
            # Shared scenes are often all called scene*.pbrt or scene*.xml: name the folder.
            name = f"{Path(scene).parent.name}/{Path(scene).stem}"
        rows.append((name, p_build, e_build, p, e))
    head = f"{'scene':<32} {'build ms (proj/Embree)':>24} {'Embree/proj':>12}"
    print(head + "".join(f" {f:>24}" for f in FIGURES))
    for name, pb, eb, p, e in rows:
        # A build of a few triangles may round to 0 ms, and a figure to 0 Mrays/s.
        ratio = f"{eb / pb:>12.2f}" if pb > 0 else f"{'-':>12}"
        line = f"{name:<32} {pb:>11.1f} / {eb:<10.1f} {ratio}"
        for f in FIGURES:
            r = f"{p[f] / e[f]:>5.2f}" if e[f] > 0 else f"{'-':>5}"
            line += f" {p[f]:>6.2f}/{e[f]:<6.2f}={r}x"
        print(line)
    print(
        "Mrays/s on one thread; each cell: project / Embree = ratio (target: >= 1.0)."
    )
    print(f"Best of {max(a.rounds, 1)} round(s) on each side.")


if __name__ == "__main__":
    main()
