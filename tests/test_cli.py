"""The entry point: help, version, and one-line errors."""

import os
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


def _read_then_close(argv: list[str], n_bytes: int) -> tuple[bytes, subprocess.CompletedProcess]:
    """Run ``snrmon ARGV`` with its stdout on a real pipe; read ``n_bytes`` of it and close
    the pipe (what ``| head -c N`` does); the bytes read and the finished process."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "snrmon", *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    assert proc.stdout is not None and proc.stderr is not None
    head = proc.stdout.read(n_bytes)
    proc.stdout.close()
    err = proc.stderr.read()
    proc.wait(timeout=120)
    return head, subprocess.CompletedProcess(argv, proc.returncode, b"", err)


@pytest.fixture(scope="module")
def long_stack(tmp_path_factory):
    """A stack whose measurement prints far more than a pipe holds (64 KiB)."""
    import numpy as np

    rng = np.random.default_rng(3)
    frames = rng.normal(100.0, 2.0, (3000, 15, 15)).astype(np.float32)
    frames[:, 7, 7] += 40.0
    path = tmp_path_factory.mktemp("pipe") / "stack.npy"
    np.save(path, frames)
    return path


@pytest.mark.parametrize("json_out", [True, False], ids=["json", "table"])
def test_a_closed_pipe_ends_the_output_quietly(long_stack, json_out):
    argv = ["measure", str(long_stack), "--at", "7,7"] + (["--json"] if json_out else [])
    head, done = _read_then_close(argv, 10)
    assert head == (b'{"n": 3000' if json_out else b" frame    ")
    assert done.returncode == 0
    assert done.stderr == b""  # no "Broken pipe", no "Exception ignored"


@pytest.mark.parametrize("argv", [["devices", "--json"], ["measure", "--help"]])
def test_a_pipe_closed_before_it_is_written_exits_0(argv):
    read, write = os.pipe()
    os.close(read)  # the reader is gone before the first byte
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "snrmon", *argv],
            stdout=write,
            stderr=subprocess.PIPE,
            check=False,
        )
    finally:
        os.close(write)
    assert (proc.returncode, proc.stderr) == (0, b"")


def test_a_broken_pipe_of_a_device_is_still_a_runtime_failure(monkeypatch, capsys):
    """Only standard output's reader going away is the end of the output; a link that breaks
    while the command works (a socket to a device) is exit 1, named."""
    from snrmon.commands import devices

    def broken(*_args, **_kwargs):
        raise BrokenPipeError(32, "Broken pipe: link to the rangefinder")

    monkeypatch.setattr(devices, "collect", broken)
    assert main(["devices"]) == 1
    assert "Broken pipe: link to the rangefinder" in capsys.readouterr().err


def test_an_optional_positional_given_after_an_option_is_taken(tmp_path, capsys):
    # gps-import SESSION [LOG]: LOG after --replace was "unrecognized arguments" (argparse fills
    # positionals from their first run only); now it is the log, and the session is checked
    missing = tmp_path / "missing.h5"
    assert main(["gps-import", str(missing), "--replace", str(tmp_path / "flight.log")]) == 2
    err = capsys.readouterr().err
    assert "unrecognized" not in err and str(missing) in err
