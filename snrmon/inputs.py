"""Checks of the files a command is given, made before any work starts.

A command that would run a flight, a replay or a recording first makes sure that what it reads
exists and is what it should be, and that where it writes can be written: one message naming
the option and the path, exit 2 (``snrmon.cli.BAD_INPUT``), never an error minutes later.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def input_file(path: str | Path, what: str) -> Path:
    """``path`` as a Path when it is an existing regular file (else FileNotFoundError or
    IsADirectoryError naming ``what``)."""
    p = Path(path)
    if p.is_dir():
        raise IsADirectoryError(f"{what} {p}: is a folder, not a file")
    if not p.is_file():
        raise FileNotFoundError(f"{what} {p} does not exist")
    return p


def is_hdf5(path: str | Path) -> bool:
    """True when the file starts with the HDF5 signature (at offset 0, as h5py writes it)."""
    with Path(path).open("rb") as fh:
        return fh.read(len(HDF5_SIGNATURE)) == HDF5_SIGNATURE


def session_file(path: str | Path, what: str = "session file") -> Path:
    """An existing snrmon session file (HDF5); anything else is one message."""
    p = input_file(path, what)
    if not is_hdf5(p):
        raise ValueError(f"{what} {p}: not an HDF5 file (a snrmon session is FILE.h5)")
    return p


def output_file(
    path: str | Path,
    what: str,
    *,
    suffixes: Iterable[str] | None = None,
    new: bool = False,
) -> Path:
    """Where a command will write: the folder must exist, the path must not be a folder,
    ``suffixes`` (lower case, with the dot) restrict its ending, and ``new`` refuses an
    existing file (a session file is never overwritten)."""
    p = Path(path)
    if suffixes is not None:
        allowed = tuple(suffixes)
        if p.suffix.lower() not in allowed:
            raise ValueError(f"{what} {p}: must end in {' or '.join(allowed)}")
    if p.is_dir():
        raise IsADirectoryError(f"{what} {p}: is a folder, not a file")
    parent = p.parent
    if not parent.is_dir():
        raise FileNotFoundError(f"{what} {p}: folder {parent} does not exist")
    if new and p.exists():
        raise FileExistsError(f"{what} {p}: already exists (a session file is never overwritten)")
    return p
