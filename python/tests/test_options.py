"""One vocabulary of render options for every shell: for every option of the library's table
(`pt.option_table()`), the command line, Python, the viewer's `POST /api/settings` and the
farm accept the same names and the same default, and refuse the same out-of-range value with
the option's name in the message."""

from __future__ import annotations

import json
import re
import subprocess
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from conftest import run_cli

import pathtracer as pt
from pathtracer import farm

TABLE: list[dict[str, Any]] = pt.option_table()


def out_of_range(opt: dict[str, Any]) -> Any:
    """A value just outside the option's allowed values (None for a switch, which has none),
    as a Python value: a tuple for several values."""
    kind = opt["kind"]
    if kind["type"] == "tuple":
        first, *rest = kind["parts"]
        return (out_of_range({"kind": first}), *(allowed_value(p) for p in rest))
    return bad_scalar(kind)


def bad_scalar(kind: dict[str, Any]) -> Any:
    if kind["type"] == "int":
        return kind["max"] + 1
    if kind["type"] == "real":
        if kind["max"] is not None:
            return kind["max"]  # the upper bound is excluded
        if kind["min"] is not None:
            return kind["min"] if not kind["closed"] else kind["min"] - 1.0
        return float("nan")
    if kind["type"] == "bit":
        return 2
    if kind["type"] == "choice":
        return "nonesuch"
    return None


def allowed_value(kind: dict[str, Any]) -> Any:
    if kind["type"] == "int":
        return kind["min"]
    if kind["type"] == "real":
        return 1.0
    return kind["choices"][0] if kind["type"] == "choice" else True


def cli_text(value: Any) -> list[str]:
    """The command line's words for a value."""
    items = value if isinstance(value, tuple) else (value,)
    return [str(v) for v in items]


def default_text(opt: dict[str, Any]) -> str:
    """The table's default as every shell prints it ('none' where unset)."""
    return "none" if opt["default"] is None else str(opt["default"])


def test_the_table_is_whole() -> None:
    names = [o["name"] for o in TABLE]
    assert len(names) == len(set(names))
    for o in TABLE:
        assert o["help"] and o["allowed"]
        assert (o["default"] is None) == (o["unset"] is not None), o
    # Every option that is not a switch has an out-of-range value to refuse.
    assert all(out_of_range(o) is not None for o in TABLE if o["kind"]["type"] != "switch")


def test_the_command_line(cli: Path) -> None:
    r = run_cli(cli, "--dry-run")
    assert r.returncode == 0, r.stderr
    printed = dict(line.split(" = ", 1) for line in r.stdout.splitlines())
    assert list(printed) == [o["name"] for o in TABLE]
    help_text = run_cli(cli, "--help").stdout
    for o in TABLE:
        assert printed[o["name"]] == default_text(o), o["name"]
        if o["flag"] is None:
            continue
        assert re.search(rf"(^|\s){re.escape(o['flag'])}\b", help_text), o["flag"]
        bad = out_of_range(o)
        if bad is None:
            continue
        r = run_cli(cli, "--dry-run", *cli_words(o, bad))
        assert r.returncode == 2, (o["name"], r.stdout)
        assert o["name"] in r.stderr, r.stderr


def cli_words(opt: dict[str, Any], bad: Any) -> list[str]:
    """The flag with `bad` in the option's place among its flag's values."""
    shared = [o for o in TABLE if o["flag"] == opt["flag"]]
    words = [str(bad) if o is opt else str(allowed_value(o["kind"])) for o in shared]
    return [opt["flag"], *words] if len(shared) > 1 else [opt["flag"], *cli_text(bad)]


def test_python() -> None:
    resolved = dict(pt.resolve_options())
    assert list(resolved) == [o["name"] for o in TABLE]
    scene = pt.load()
    for o in TABLE:
        assert resolved[o["name"]] == default_text(o), o["name"]
        bad = out_of_range(o)
        if bad is None:
            continue
        with pytest.raises(pt.OptionError, match=o["name"]):
            if o["python"] == "load":
                pt.load(**{o["name"]: bad})
            else:
                pt.resolve_options(scene, **{o["name"]: bad})
        assert issubclass(pt.OptionError, pt.Error) and issubclass(pt.OptionError, ValueError)


def wrong_type(opt: dict[str, Any]) -> Any:
    """A value of the wrong type for the option: a word for a number, a number for a word."""
    return 3 if opt["kind"]["type"] == "choice" else "lots"


def test_render_refuses_bad_keywords_in_the_users_words() -> None:
    """`pt.render` itself refuses each keyword's out-of-range and wrong-typed values with
    `pathtracer.Error` naming the option, never a binding's OverflowError or TypeError."""
    scene = pt.load()
    for o in TABLE:
        if o["python"] == "load":
            continue
        for bad in (out_of_range(o), wrong_type(o)):
            if bad is None:
                continue
            with pytest.raises(pt.Error, match=o["name"]):
                pt.render(scene, **{o["name"]: bad})


def test_the_farm(capsys: pytest.CaptureFixture[str]) -> None:
    a = farm.parse_args(["-f", "x.exr"])
    resolved = dict(pt.resolve_options(pt.load(), **a.options))
    opts = farm.render_options(pt.load(), a)
    for o in TABLE:
        if o["python"] == "load":
            assert str(getattr(a, o["name"])).lower() == default_text(o), o["name"]
        else:
            assert resolved[o["name"]] == default_text(o), o["name"]
        if o["name"] in opts:
            assert str(opts[o["name"]]) == default_text(o), o["name"]
        bad = out_of_range(o)
        if o["flag"] is None or bad is None:
            continue
        with pytest.raises(SystemExit) as e:
            farm.parse_args(["-f", "x.exr", *cli_words(o, bad)])
        assert e.value.code == 2
        assert o["name"] in capsys.readouterr().err, o["name"]


@pytest.fixture(scope="module")
def viewer(cli: Path) -> Iterator[str]:
    """A running `pathtracer view` of the built-in scene: its URL with the token."""
    p = subprocess.Popen(
        [str(cli), "view", "-r", "32", "24", "-t", "1"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        line = p.stdout.readline() if p.stdout else ""
        assert line.startswith("open "), line
        yield line.split()[1]
    finally:
        p.terminate()
        p.wait(timeout=30)


def api(url: str, path: str, body: dict[str, Any] | None = None) -> tuple[int, str]:
    base, token = url.split("/?token=")
    req = urllib.request.Request(
        f"{base}{path}?token={token}",
        data=None if body is None else json.dumps(body).encode(),
        method="GET" if body is None else "POST",
    )
    try:
        with urllib.request.urlopen(req, timeout=30) as r:
            return r.status, r.read().decode()
    except urllib.error.HTTPError as e:
        return e.code, e.read().decode()


def json_default(v: Any) -> str:
    if isinstance(v, bool):
        return str(v).lower()
    return "none" if v is None else str(v)


def test_the_viewer(viewer: str) -> None:
    status, text = api(viewer, "/api/state")
    assert status == 200
    settings = json.loads(text)["settings"]
    fields = {o["json"]: o for o in TABLE if o["json"] is not None}
    assert set(settings) == set(fields)
    for field, o in fields.items():
        if o["default"] is not None:  # the others are the scene's (its lens)
            assert json_default(settings[field]) == default_text(o), field
        bad = out_of_range(o)
        if bad is None:
            continue
        status, text = api(
            viewer, "/api/settings", {field: list(bad) if isinstance(bad, tuple) else bad}
        )
        assert status == 422, (field, status, text)
        assert o["name"] in text, text
    status, text = api(viewer, "/api/state")
    assert json.loads(text)["settings"] == settings, "a refused value changed nothing"


def test_the_readme_lists_every_flag() -> None:
    """The README's flag table has a row for every flag of the table."""
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    rows = [line for line in readme.splitlines() if line.startswith("| `-")]
    for o in TABLE:
        if o["flag"] is not None:
            assert any(r.startswith(f"| `{o['flag']}") for r in rows), o["flag"]
