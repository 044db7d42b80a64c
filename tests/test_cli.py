"""The entry point: help, version, and one-line errors."""

import subprocess
import sys

import pytest

from snrmon import __version__
from snrmon.cli import main


def test_version(capsys):
    try:
        main(["--version"])
    except SystemExit as exc:
        assert exc.code == 0
    assert capsys.readouterr().out.strip() == f"snrmon {__version__}"


def test_help_lists_subcommands(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    assert "bench" in out


def test_python_dash_m_runs():
    proc = subprocess.run(
        [sys.executable, "-m", "snrmon", "--version"], capture_output=True, text=True, check=False
    )
    assert proc.returncode == 0
    assert proc.stdout.strip() == f"snrmon {__version__}"


def test_no_command_prints_help_and_fails(capsys):
    assert main([]) == 2
    assert "COMMAND" in capsys.readouterr().out


# What building the parser must not load: the numerical stack and the device and file layers
# (each command imports them when it runs, so `snrmon COMMAND --help` starts at once; its CPU
# time is the `cli` benchmark, `snrmon bench --only cli`).
HEAVY_MODULES = ("numpy", "scipy", "numba", "h5py", "xarray", "matplotlib", "PySide6", "dask")
HEAVY_PACKAGES = ("snrmon.acquisition", "snrmon.model", "snrmon.rig", "snrmon.sim", "snrmon.gui")


def test_the_parser_and_the_public_api_name_load_nothing_heavy():
    code = (
        "import sys, snrmon\n"
        "from snrmon.cli import build_parser\n"
        "build_parser()\n"
        "print('\\n'.join(sorted(sys.modules)))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    loaded = set(proc.stdout.split())
    assert "snrmon.commands.measure" in loaded  # every command's register() ran
    heavy = sorted(
        m
        for m in loaded
        if m.split(".")[0] in HEAVY_MODULES
        or m.startswith(tuple(p + "." for p in HEAVY_PACKAGES))
        or m in HEAVY_PACKAGES
    )
    assert heavy == []
