"""Shared helpers: the command-line binary (built when missing) and the shared test data."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def cli_path() -> Path:
    """The `pathtracer` binary of this checkout (`cargo build --release` when missing)."""
    exe = Path(os.environ.get("PATHTRACER_BIN", ROOT / "target" / "release" / "pathtracer"))
    if not exe.exists():
        subprocess.run(["cargo", "build", "--release", "--bin", "pathtracer"], cwd=ROOT, check=True)
    return exe


def shared() -> Path | None:
    """`../shared` beside the project's root, or None (with a notice) when absent."""
    p = ROOT.parent / "shared"
    if not (p / "scenes").is_dir():
        if os.environ.get("CI") == "true":
            raise RuntimeError(
                "../shared is absent: under CI (CI=true) the tests that need it fail"
            )
        print("notice: ../shared is absent; skipping the tests that need it")
        return None
    return p


@pytest.fixture(scope="session")
def cli() -> Path:
    return cli_path()


def run_cli(cli: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(cli), *args], capture_output=True, text=True, timeout=600, check=False
    )
