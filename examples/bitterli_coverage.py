#!/usr/bin/env python3
"""What the renderer makes of every scene in a folder tree: one line per scene file.

    python3 examples/bitterli_coverage.py ROOT [--pathtracer BIN] [--stand-ins] [--markdown]

Finds every pbrt-v4 file (a `.pbrt` with `WorldBegin`) and Mitsuba 3 file (a `.xml` whose root
is `<scene version="3.…">`; Mitsuba 0.6 files are left out) under ROOT, loads each with `pathtracer --info` (nothing is rendered) and prints
one line per scene: `loaded`, `absent` with the files the scene names that are not there, or
the error; then every "not supported" warning, counted by kind (the warning's text without its
file and line).

Repositories of research scenes often leave out their largest files (Bitterli's scenes in the
`gonsolo/bitterli` repository do). With `--stand-ins`, a scene that stops at an absent file is
copied to a temporary folder, a small stand-in of the same kind is written in the absent file's
place (a grey 2×2 image, one triangle, an empty include), and the scene is loaded again, so
that what the rest of it asks for is seen too; the line then says how many stand-ins it took.
The tree itself is never written to.
"""

from __future__ import annotations

import argparse
import collections
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

MISSING = ("No such file or directory", "os error 2", "is not a readable file")
# Most stand-ins one scene may take before it is reported absent.
MAX_STAND_INS = 64


@dataclass
class Outcome:
    """What loading one scene gave."""

    scene: str
    status: str = "loaded"
    error: str = ""
    absent: list[str] = field(default_factory=list)
    stand_ins: int = 0
    warnings: collections.Counter[str] = field(default_factory=collections.Counter)


def scene_files(root: Path) -> list[Path]:
    """The pbrt-v4 and Mitsuba scene files under `root`, sorted."""
    found = []
    for path in sorted(root.rglob("*")):
        if path.suffix == ".pbrt" and path.is_file():
            if b"WorldBegin" in path.read_bytes():
                found.append(path)
        elif path.suffix == ".xml" and path.is_file():
            # Mitsuba 3 files only: `<scene version="3.…">` (or 2); 0.x files are Mitsuba 0.6's.
            head = path.read_bytes()[:4096].decode("utf-8", "replace")
            version = re.search(r"<scene\s+version=\"(\d+)", head)
            if version and int(version.group(1)) >= 2:
                found.append(path)
    return found


def warning_kind(line: str) -> str:
    """A warning's text without `file:line:col:` and quoted values that vary."""
    text = re.sub(r"^warning:\s*", "", line.strip())
    text = re.sub(r"^\S+?:\d+(:\d+)?:\s*", "", text)
    return text


def absent_path(message: str, cwd: Path) -> str | None:
    """The file an error says is missing: among the runs of words of the `: `-separated parts
    of the message that look like a file name (an extension) and are not there, the longest
    whose first folder exists (file names may hold spaces)."""
    if not any(m in message for m in MISSING):
        return None
    candidates = []
    for part in message.split(": "):
        words = part.split(" ")
        for start in range(len(words)):
            for end in range(start + 1, len(words) + 1):
                candidate = " ".join(words[start:end]).strip("\"'")
                first = Path(candidate).parts[0] if Path(candidate).parts else ""
                if (
                    re.search(r"\.[A-Za-z0-9]{1,5}$", candidate)
                    and not (cwd / candidate).exists()
                    and (cwd / first).is_dir()
                ):
                    candidates.append(candidate)
    return max(candidates, key=len, default=None)


def stand_in_bytes(path: str) -> bytes:
    """A small file of the kind `path`'s extension names."""
    ext = Path(path).suffix.lower()
    if ext == ".tga":
        # An uncompressed 2×2 grey TGA.
        return bytes([0, 0, 3]) + bytes(9) + struct.pack("<HHBB", 2, 2, 8, 0) + bytes([128] * 4)
    if ext in (".png", ".jpg", ".jpeg"):
        # A 1×1 grey PNG (a JPEG's stand-in too: the renderer reads an image by its bytes).
        def chunk(kind: bytes, data: bytes) -> bytes:
            body = kind + data
            return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

        ihdr = struct.pack(">IIBBBBB", 1, 1, 8, 0, 0, 0, 0)
        idat = zlib.compress(bytes([0, 128]))
        return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")
    if ext in (".exr", ".hdr"):
        # A 1×1 Radiance image (read by its magic number, whatever the extension says).
        return b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 1\n" + bytes([128, 128, 128, 128])
    if ext == ".pfm":
        return b"PF\n1 1\n-1.0\n" + struct.pack("<3f", 0.5, 0.5, 0.5)
    if ext == ".ply":
        return (
            b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
            b"property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
            b"end_header\n0 0 0\n0.01 0 0\n0 0.01 0\n3 0 1 2\n"
        )
    if ext == ".obj":
        return b"v 0 0 0\nv 0.01 0 0\nv 0 0.01 0\nf 1 2 3\n"
    return b""


def load(binary: str, scene: Path, cwd: Path) -> tuple[int, str]:
    """`pathtracer --info` on `scene`: exit status and standard error."""
    run = subprocess.run(
        [binary, "--info", str(scene)],
        check=False,
        cwd=cwd,
        capture_output=True,
        text=True,
        errors="replace",
        timeout=600,
    )
    return run.returncode, run.stderr


def check(binary: str, root: Path, scene: Path, stand_ins: bool) -> Outcome:
    """Loads `scene` (relative to `root`), with stand-ins for absent files if asked."""
    outcome = Outcome(scene=str(scene))
    code, err = load(binary, scene, root)
    workdir: Path | None = None
    try:
        while code != 0:
            message = next((line for line in err.splitlines() if line.startswith("error")), err)
            missing = absent_path(message, workdir or root)
            if missing is None:
                outcome.status, outcome.error = "error", message.strip()
                break
            outcome.absent.append(missing)
            if not stand_ins or len(outcome.absent) > MAX_STAND_INS:
                outcome.status = "absent"
                break
            if workdir is None:
                workdir = Path(tempfile.mkdtemp(prefix="coverage-"))
                shutil.copytree(root / scene.parts[0], workdir / scene.parts[0], symlinks=True)
            target = workdir / missing
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(stand_in_bytes(missing))
            outcome.stand_ins += 1
            code, err = load(binary, scene, workdir)
    finally:
        if workdir is not None:
            shutil.rmtree(workdir, ignore_errors=True)
    for line in err.splitlines():
        if line.startswith("warning") and "not supported" in line:
            outcome.warnings[warning_kind(line)] += 1
    return outcome


def shortened(files: list[str], most: int = 4) -> str:
    """`files` joined, the first `most` of a longer list and their count."""
    if len(files) <= most:
        return ", ".join(files)
    return ", ".join(files[:most]) + f", … ({len(files)} in all)"


def describe(o: Outcome) -> str:
    """One line: the scene, its status, and its warnings by kind."""
    if o.status == "loaded":
        status = "loaded" if not o.stand_ins else f"loaded with {o.stand_ins} stand-in(s)"
    elif o.status == "absent":
        status = "absent: " + shortened(o.absent)
    else:
        status = "error: " + o.error
    warnings = "; ".join(f"{k} ×{n}" for k, n in sorted(o.warnings.items()))
    return f"{o.scene}  {status}" + (f"  [{warnings}]" if warnings else "")


def markdown(outcomes: list[Outcome]) -> str:
    """The outcomes as a Markdown table."""
    rows = ["| scene | loads | absent from the tree (stand-ins) | not supported (count) |", "|---|---|---|---|"]
    for o in outcomes:
        loads = {"loaded": "yes", "absent": "absent files", "error": "**no**: " + o.error}[o.status]
        shown = [f"`{a}`" for a in o.absent[:4]] + ([f"… ({len(o.absent)} in all)"] if len(o.absent) > 4 else [])
        absent = ", ".join(shown) or "—"
        warnings = "<br>".join(f"{k} (×{n})" for k, n in sorted(o.warnings.items())) or "—"
        rows.append(f"| `{o.scene}` | {loads} | {absent} | {warnings} |")
    return "\n".join(rows)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("root", type=Path)
    ap.add_argument("--pathtracer", default=None, help="the binary (default: target/release/pathtracer)")
    ap.add_argument("--stand-ins", action="store_true", help="load past absent files with stand-ins")
    ap.add_argument("--markdown", action="store_true", help="print a Markdown table")
    args = ap.parse_args()
    binary = args.pathtracer or str(Path(__file__).resolve().parent.parent / "target/release/pathtracer")
    if not os.access(binary, os.X_OK):
        print(f"error: {binary} is not an executable (cargo build --release first)", file=sys.stderr)
        return 2
    root = args.root.resolve()
    outcomes = []
    for scene in scene_files(root):
        o = check(binary, root, scene.relative_to(root), args.stand_ins)
        outcomes.append(o)
        if not args.markdown:
            print(describe(o), flush=True)
    if args.markdown:
        print(markdown(outcomes))
    totals = collections.Counter(o.status for o in outcomes)
    summary = ", ".join(f"{n} {s}" for s, n in sorted(totals.items()))
    print(f"{len(outcomes)} scenes: {summary}", file=sys.stderr)
    return 1 if totals["error"] else 0


if __name__ == "__main__":
    sys.exit(main())
