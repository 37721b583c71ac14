#!/usr/bin/env python3
"""Denoising against the references: for every reference scene of ../shared/refs that this
renderer reads, the relative MSE (../shared/tools/imgcmp.py) of the noisy and the denoised
image (`pathtracer --denoise`) at 4, 16 and 64 spp, and at equal time: the denoised 16-spp
image against a noisy render given the same wall time (its render and denoising time) with
`--time-limit`. Prints a Markdown table; with --crops DIR, writes the images it compares.

    python3 benches/denoise_quality.py [--bin target/release/pathtracer] [--only NAME]

Needs Open Image Denoise (`pip install pyoidn`; see docs/denoise.md) and numpy + OpenEXR for
imgcmp.py.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
CBOX_OBJ_VIEW = [
    "--lookat",
    "0",
    "1",
    "3.5",
    "0",
    "1",
    "0",
    "0",
    "1",
    "0",
    "--fov",
    "40",
]

# Name, the command line's arguments (scene and flags, relative to ../shared), reference.
SCENES: list[tuple[str, list[str], str]] = [
    *(
        (
            f"CBspheres_m{m}",
            ["scenes/cs184/sky/CBspheres.dae", "-m", str(m)],
            f"CBspheres_m{m}",
        )
        for m in range(1, 6)
    ),
    (
        "CBspheres_m100",
        ["scenes/cs184/sky/CBspheres.dae", "-m", "100"],
        "CBspheres_m100",
    ),
    (
        "CBspheres_lambertian",
        ["scenes/cs184/sky/CBspheres_lambertian.dae", "-m", "100"],
        "CBspheres_lambertian_m100",
    ),
    ("CBbunny", ["scenes/cs184/sky/CBbunny.dae", "-m", "100"], "CBbunny_m100"),
    (
        "CBspheres_microfacet",
        ["scenes/cs184/sky/CBspheres_microfacet_al_ag.dae", "-m", "100"],
        "CBspheres_microfacet_al_ag_m100",
    ),
    (
        "bunny_unlit_sunrise",
        ["scenes/cs184/sky/bunny_unlit.dae", "-e", "envmaps/sunrise.exr", "-m", "100"],
        "bunny_unlit_sunrise_m100",
    ),
    (
        "CornellBox-Original",
        ["scenes/real/obj/CornellBox-Original.obj", "-m", "100", *CBOX_OBJ_VIEW],
        "CornellBox-Original_obj",
    ),
    (
        "coffee (pbrt-v4)",
        ["scenes/pbrt-v4/coffee/scene-v4.pbrt", "-r", "200", "250"],
        "pbrt-v4/coffee",
    ),
    (
        "veach-mis (pbrt-v4)",
        ["scenes/pbrt-v4/veach-mis/scene-v4.pbrt", "-r", "320", "180"],
        "pbrt-v4/veach-mis",
    ),
    (
        "classroom (Mitsuba)",
        ["scenes/mitsuba/classroom/scene_v3.xml"],
        "mitsuba/classroom",
    ),
    (
        "cornell-box (Mitsuba)",
        ["scenes/mitsuba/cornell-box/scene_v3.xml"],
        "mitsuba/cornell-box",
    ),
]
SPPS = (4, 16, 64)


def shared_args(args: list[str]) -> list[str]:
    """The arguments with the shared files' paths made absolute."""
    return [str(SHARED / a) if (SHARED / a).is_file() else a for a in args]


def render(binary: str, args: list[str], out: Path) -> tuple[float, float, str]:
    """Runs the command line; its render and denoising seconds (0 without --denoise) and the
    samples per pixel it reports."""
    cmd = [binary, *args, "-t", "2", "-f", str(out)]
    r = subprocess.run(cmd, check=False, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(args)}: {r.stderr.strip()}")
    rendered = re.search(
        r"rendered \S+ at ([0-9.]+) (?:\([^)]*\) )?spp .* in ([0-9.]+) s", r.stderr
    )
    denoised = re.search(r"denoised in ([0-9.]+) s", r.stderr)
    return (
        float(rendered.group(2)) if rendered else 0.0,
        float(denoised.group(1)) if denoised else 0.0,
        rendered.group(1) if rendered else "?",
    )


def rel_mse(image: Path, reference: Path) -> float:
    """imgcmp.py's relMSE of `image` against `reference`."""
    tool = SHARED / "tools" / "imgcmp.py"
    r = subprocess.run(
        [sys.executable, str(tool), str(image), str(reference)],
        check=False,
        capture_output=True,
        text=True,
    )
    m = re.search(r"relmse=([0-9.eE+-]+)", r.stdout)
    if m is None:
        sys.exit(f"imgcmp.py {image}: {r.stdout}{r.stderr}")
    return float(m.group(1))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "pathtracer"))
    ap.add_argument("--only", help="only scenes whose name contains this")
    ap.add_argument(
        "--crops", type=Path, help="keep the compared images in this folder"
    )
    a = ap.parse_args()
    if not SHARED.is_dir():
        sys.exit("../shared is absent")
    tmp = Path(tempfile.mkdtemp(prefix="denoise-quality-"))
    print(
        "| scene | noisy 4 | denoised 4 | noisy 16 | denoised 16 | noisy 64 | denoised 64 |"
        " equal time: noisy (spp) | render + denoise 16 spp, s |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for name, args, ref in SCENES:
        if a.only and a.only not in name:
            continue
        reference = SHARED / "refs" / f"{ref}.exr"
        flags = shared_args(args)
        row = [name]
        seconds = 0.0
        key = re.sub(r"[^A-Za-z0-9]+", "_", name).strip("_")
        for spp in SPPS:
            out = tmp / f"{key}_{spp}.exr"
            r, d, _ = render(a.bin, [*flags, "-s", str(spp), "--denoise"], out)
            noisy = out.with_name(f"{out.stem}_noisy.exr")
            row += [
                f"{rel_mse(noisy, reference):.4f}",
                f"{rel_mse(out, reference):.4f}",
            ]
            if spp == 16:
                seconds = r + d
        same = tmp / f"{key}_equal_time.exr"
        # A time limit renders whole passes of one sample per pixel until it is spent.
        limit = ["-s", "100000", "--time-limit", f"{seconds:.3f}"]
        _, _, spp = render(a.bin, [*flags, *limit], same)
        row += [f"{rel_mse(same, reference):.4f} ({spp})", f"{seconds:.2f}"]
        print("| " + " | ".join(row) + " |", flush=True)
    if a.crops:
        a.crops.mkdir(parents=True, exist_ok=True)
        for f in tmp.glob("*.exr"):
            shutil.copy(f, a.crops / f.name)
    shutil.rmtree(tmp)
    return 0


if __name__ == "__main__":
    sys.exit(main())
