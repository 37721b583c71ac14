#!/usr/bin/env python3
"""The viewer's denoised display and the render thread: the time `pathtracer view` takes to
reach its target (the film's age when the last pass is published) with denoising off and on,
and how long after that the last pass is shown denoised. With --old BIN, also BIN's time with
denoising off, the runs alternating, for a before/after ratio of the render thread's speed.

    python3 benches/viewer_denoise.py [--bin target/release/pathtracer] [--old BIN]
        [--scene FILE] [--spp 64] [--rounds 6]

Denoising needs Open Image Denoise (`pip install pyoidn`; see docs/denoise.md).
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import subprocess
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT.parent / "shared" / "scenes" / "cs184" / "sky" / "CBspheres_lambertian.dae"


def wait(base: str, token: str, done: str, spp: int) -> dict:
    """Polls the state until `done` (a state field) reaches `spp`; returns that state."""
    t0 = time.monotonic()
    while True:
        with urllib.request.urlopen(f"{base}/api/state?token={token}") as r:
            st = json.load(r)
        if st[done] >= spp and not st["preview"]:
            return st
        if time.monotonic() - t0 > 600:
            raise SystemExit(f"{done} did not reach {spp} in 600 s")
        time.sleep(0.02)


def run(
    binary: str, scene: Path, spp: int, denoise: bool
) -> tuple[float, float | None]:
    """Seconds to the target, and (with `denoise`) from then to its denoised image."""
    args = [binary, "view", "-t", "2", "-r", "480", "360", "-s", str(spp), str(scene)]
    if denoise:
        args.insert(2, "--denoise")
    p = subprocess.Popen(
        args, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True
    )
    try:
        assert p.stdout is not None
        found = re.search(r"(http://\S+)/\?token=(\w+)", p.stdout.readline())
        if not found:
            raise SystemExit(f"{binary} view printed no URL")
        base, token = found.group(1), found.group(2)
        rendered = wait(base, token, "passes", spp)["elapsed"]
        if not denoise:
            return rendered, None
        return rendered, wait(base, token, "denoised_passes", spp)["elapsed"] - rendered
    finally:
        p.terminate()
        p.wait()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "pathtracer"))
    ap.add_argument("--old", help="an earlier build, timed with denoising off")
    ap.add_argument("--scene", type=Path, default=SCENE)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--rounds", type=int, default=6)
    a = ap.parse_args()
    times: dict[str, list[float]] = {"off": [], "on": [], "old": [], "lag": []}
    for r in range(a.rounds):
        order = ["off", "on", "old"] if r % 2 == 0 else ["old", "on", "off"]
        for what in order:
            if what == "old" and not a.old:
                continue
            binary = a.old if what == "old" else a.bin
            t, lag = run(binary, a.scene, a.spp, what == "on")
            times[what].append(t)
            if lag is not None:
                times["lag"].append(lag)
    med = {k: statistics.median(v) for k, v in times.items() if v}
    for k, v in times.items():
        if v:
            print(f"{k:>4}: median {med[k]:.3f} s  ({' '.join(f'{x:.2f}' for x in v)})")
    print(f"on / off: {med['on'] / med['off']:.3f}")
    if "old" in med:
        print(f"off / old: {med['off'] / med['old']:.4f}")


if __name__ == "__main__":
    main()
