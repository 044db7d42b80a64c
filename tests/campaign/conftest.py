"""Two small recorded sessions, built once for the campaign and GPS-import tests with
``snrmon hil --out`` (short flights: two stops, 4 s hovers at four times real time, LWIR only:
a session is ~400 MB and ~9 s to record)."""

from __future__ import annotations

from pathlib import Path

import pytest

from snrmon.cli import main

SEEDS = (0, 1)


def record(path: Path, seed: int) -> Path:
    argv = [
        "hil",
        "--out",
        str(path),
        "--stops",
        "37,126",
        "--hover-s",
        "4",
        "--speed",
        "4",
        "--camera",
        "lwir",
        "--seed",
        str(seed),
        "--json",
    ]
    assert main(argv) == 0, f"snrmon hil --out {path} failed"
    return path


@pytest.fixture(scope="session")
def hil_sessions(tmp_path_factory) -> list[Path]:
    folder = tmp_path_factory.mktemp("campaign-sessions")
    return [record(folder / f"flight-{seed}.h5", seed) for seed in SEEDS]
