"""The base install is the library and the command line; the console and the campaign's cluster
are extras. Without them (their modules made unimportable in a fresh interpreter) the library
and every other command work, and a command that needs one says which, exit 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

BLOCK = {
    "gui": ("PySide6", "pyqtgraph"),
    "campaign": ("dask", "distributed", "pyarrow"),
}


def run_without(extras: tuple[str, ...], code: str, cwd: Path) -> subprocess.CompletedProcess:
    blocked = [m for e in extras for m in BLOCK[e]]
    prelude = "import sys\n" + "".join(f"sys.modules[{m!r}] = None\n" for m in blocked)
    return subprocess.run(
        [sys.executable, "-c", prelude + code],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=120,
    )


def cli(argv: list[str]) -> str:
    return f"from snrmon.cli import main\nsys.exit(main({argv!r}))\n"


@pytest.mark.parametrize(
    ("extra", "argv", "what"),
    [
        ("gui", ["demo", "--headless"], "the console demo needs PySide6"),
        ("gui", ["gui", "--replay", "x.h5"], "the console needs PySide6"),
        ("campaign", ["campaign", "x.h5", "--out", "out"], "a campaign needs dask"),
        ("gui", ["bench", "--only", "gui"], "bench --only gui needs PySide6"),
    ],
)
def test_a_command_without_its_extra_says_which_to_install(extra, argv, what, tmp_path):
    r = run_without((extra,), cli(argv), tmp_path)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith(f"snrmon {argv[0]}: error: {what}, which is not installed")
    assert f"pip install 'snrmon[{extra}]'" in lines[0]
    assert not list(tmp_path.iterdir())  # refused before any work


def test_the_library_and_the_other_commands_work_without_the_extras(tmp_path):
    code = (
        "import snrmon\n"
        "ds = snrmon.predict('mwir', 'uav1', [199.0], band=False, expected=False)\n"
        "print(round(float(ds['small'][0]), 1))\n" + cli(["model", "snr", "--sensor", "lwir", "--target", "uav1", "--ranges", "199"])
    )
    r = run_without(("gui", "campaign"), code, tmp_path)
    assert r.returncode == 0, r.stderr
    first = r.stdout.splitlines()[0]
    assert float(first) > 0
    help_text = run_without(("gui", "campaign"), cli(["--help"]), tmp_path)
    assert help_text.returncode == 0 and "demo" in help_text.stdout
