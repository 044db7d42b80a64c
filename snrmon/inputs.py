"""Checks of the files a command is given, made before any work starts.

A command that would run a flight, a replay or a recording first makes sure that what it reads
exists and is what it should be, and that where it writes can be written: one message naming
the option and the path and what is wrong, exit 2 (``snrmon.cli.BAD_INPUT``), never an error
minutes later, never the HDF5 library's text or a Python error number.

What is checked, in order (each a ``ValueError`` or an ``OSError`` subclass that names a path):

* any input (:func:`input_file`): it exists, it is a file and not a folder, it is not empty;
  a text one (:func:`snrmon.acquisition.config.utf8_text`) is UTF-8;
* a session (:func:`session_file`): an HDF5 file (its signature), one the HDF5 library can open
  (a truncated or damaged one is named as such), a snrmon session (its ``format`` attribute) whose
  streams all read, when a camera is asked for one that holds that camera, and for
  a command that measures frames one with a frame;
* a frame stack of another tool (:func:`stack_file`): what its name's ending says it is (an
  ``.h5`` that is not HDF5, a ``.tif`` that is not a TIFF, an ``.npy`` that is not an array);
* where output goes (:func:`output_file`, :func:`output_folder`): its folder exists, a file is
  not a folder and a folder is not a file, a session is never overwritten.

And every number an option takes, when argparse reads it (:class:`Number`,
:class:`NumberList`, :class:`Size`): finite, within the range where the work is possible, so a
value that would hang a command or ask for terabytes is refused with one line naming the option
and the value (``argument --ranges: must be ... got '0.0001'``), exit 2, before anything starts.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Iterable
from pathlib import Path

from snrmon.limits import (
    MAX_DURATION_S,
    MAX_FRAME_PX,
    MAX_SEED,
    MAX_STOP_RANGE_M,
)

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
# The first bytes of what a stack file's ending promises (the formats whose header is fixed).
STACK_SIGNATURES: dict[str, tuple[bytes, ...]] = {
    ".h5": (HDF5_SIGNATURE,),
    ".hdf5": (HDF5_SIGNATURE,),
    ".tif": (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+"),
    ".tiff": (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+"),
    ".npy": (b"\x93NUMPY",),
    ".png": (b"\x89PNG\r\n\x1a\n",),
    ".seq": (b"FFF\x00",),
    ".csq": (b"FFF\x00",),
    ".fff": (b"FFF\x00",),
    ".jpg": (b"\xff\xd8\xff",),
    ".jpeg": (b"\xff\xd8\xff",),
}
STACK_KINDS = {
    ".h5": "an HDF5 file",
    ".hdf5": "an HDF5 file",
    ".tif": "a TIFF file",
    ".tiff": "a TIFF file",
    ".npy": "a numpy .npy array",
    ".png": "a PNG image",
    ".seq": "a FLIR SEQ recording (FFF frames)",
    ".csq": "a FLIR CSQ recording (FFF frames)",
    ".fff": "a FLIR FFF frame",
    ".jpg": "a JPEG image",
    ".jpeg": "a JPEG image",
}


def input_file(path: str | Path, what: str) -> Path:
    """``path`` as a Path when it is an existing, non-empty regular file (else
    FileNotFoundError, IsADirectoryError or ValueError naming ``what`` and the path)."""
    p = Path(path)
    if p.is_dir():
        raise IsADirectoryError(f"{what} {p}: is a folder, not a file")
    if not p.is_file():
        raise FileNotFoundError(f"{what} {p} does not exist")
    if p.stat().st_size == 0:
        raise ValueError(f"{what} {p}: is empty (0 bytes)")
    return p


def starts_with(path: str | Path, signatures: Iterable[bytes]) -> bool:
    """True when the file begins with one of ``signatures``."""
    sigs = tuple(signatures)
    with Path(path).open("rb") as fh:
        head = fh.read(max(len(s) for s in sigs))
    return any(head.startswith(s) for s in sigs)


def is_hdf5(path: str | Path) -> bool:
    """True when the file starts with the HDF5 signature (at offset 0, as h5py writes it)."""
    return starts_with(path, (HDF5_SIGNATURE,))


def session_file(
    path: str | Path,
    what: str = "session file",
    *,
    camera: str | None = None,
    with_frames: bool = False,
) -> Path:
    """An existing snrmon session file (HDF5) whose streams read, holding ``camera`` when one is
    asked for and, with ``with_frames``, a frame of some camera (a command that measures frames
    has nothing to do without one); anything else is one message naming the file and what is
    wrong."""
    p = input_file(path, what)
    if not is_hdf5(p):
        raise ValueError(f"{what} {p}: not an HDF5 file (a snrmon session is an HDF5 .h5 file)")
    cameras = session_frame_counts(p, what)
    if with_frames and not any(cameras.values()):
        have = ", ".join(f"{name} {n}" for name, n in cameras.items()) or "no camera"
        raise ValueError(f"{what} {p}: no frames in it (frames per camera: {have})")
    if camera is not None and camera not in cameras:
        have = ", ".join(cameras) or "none"
        raise ValueError(f"{what} {p}: no camera {camera!r} in it (cameras: {have})")
    return p


def session_frame_counts(path: Path, what: str = "session file") -> dict[str, int]:
    """The frame count of each camera of the session at ``path``, read through the session
    reader (every stream but the pixels is read: a damaged file fails here, not minutes into a
    replay)."""
    from snrmon.acquisition.record.reader import open_session

    try:
        with open_session(path) as f:
            counts = {name: int(cam.n_frames) for name, cam in f.cameras.items()}
            for cam in f.cameras.values():
                if cam.n_frames:  # the pixels' index: the first and the last frame read
                    cam.frame(0)
                    cam.frame(cam.n_frames - 1)
            return counts
    except ValueError as exc:
        if "not a snrmon session" in str(exc):
            raise ValueError(
                f"{what} {path}: an HDF5 file but not a snrmon session (no format attribute)"
            ) from None
        raise ValueError(f"{what} {path}: damaged session file ({_first_line(exc)})") from None
    except OSError as exc:
        text = _first_line(exc)
        if text.startswith("cannot open session file"):  # the reader's own prefix: said here
            text = text.split(": ", 1)[-1]
        why = "truncated" if "truncated" in text or "eof" in text else "damaged"
        raise ValueError(f"{what} {path}: {why} HDF5 file ({text})") from None
    except (KeyError, TypeError, IndexError, AttributeError, RuntimeError) as exc:
        # A dataset or attribute of the layout missing or of the wrong kind.
        raise ValueError(
            f"{what} {path}: not a readable snrmon session ({type(exc).__name__}: "
            f"{_first_line(exc)})"
        ) from None


def _first_line(exc: BaseException) -> str:
    text = str(exc.args[0]) if isinstance(exc, KeyError) and exc.args else str(exc)
    lines = text.strip().splitlines()
    return lines[0] if lines else type(exc).__name__


def stack_file(path: str | Path, what: str = "stack") -> Path:
    """A frame stack of another tool: exists, not empty, and begins as its ending says (raw
    files with a ``.json`` descriptor and videos are checked by their readers)."""
    p = Path(path)
    if p.suffix.lower() == ".json" or Path(f"{p}.json").is_file():
        data = p.with_suffix("") if p.suffix.lower() == ".json" else p
        input_file(data, what)
        input_file(Path(f"{data}.json"), f"{what} descriptor")
        return p
    input_file(p, what)
    sigs = STACK_SIGNATURES.get(p.suffix.lower())
    if sigs is not None and not starts_with(p, sigs):
        raise ValueError(f"{what} {p}: not {STACK_KINDS[p.suffix.lower()]} (its first bytes)")
    return p


SESSION_SUFFIXES = (".h5", ".hdf5")


def is_session_recording(path: str | Path, what: str = "recording") -> bool:
    """True for a snrmon session with frames (checked whole: :func:`session_file`), False for
    another tool's recording (checked as its ending says: :func:`stack_file`). A file named
    ``.h5`` or starting as HDF5 is a session or nothing."""
    p = Path(path)
    if p.suffix.lower() in SESSION_SUFFIXES or (p.is_file() and p.stat().st_size and is_hdf5(p)):
        session_file(p, with_frames=True)
        return True
    stack_file(p, what)
    return False


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


def output_folder(path: str | Path, what: str) -> Path:
    """A folder a command will write into: an existing folder, or a new one whose parent
    exists (it is not made here: nothing is written before every input passed)."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise NotADirectoryError(f"{what} {p}: is a file, not a folder")
    if not p.exists() and not p.parent.is_dir():
        raise FileNotFoundError(f"{what} {p}: its folder {p.parent} does not exist")
    return p


def _g(value: float) -> str:
    return f"{value:.10g}" if isinstance(value, float) else str(value)


class Number:
    """An argparse type: a finite number from ``lo`` to ``hi`` (``lo`` itself excluded with
    ``above``), an integer with ``integer``; anything else one line naming the value."""

    def __init__(
        self,
        lo: float,
        hi: float,
        *,
        integer: bool = False,
        above: bool = False,
        odd: bool = False,
        unit: str = "",
    ) -> None:
        self.lo, self.hi, self.integer, self.above, self.odd = lo, hi, integer, above, odd
        self.unit = f" {unit}" if unit else ""
        self.__name__ = "integer" if integer else "number"  # argparse names a type by it

    def describe(self) -> str:
        """The range in words, as the error says it."""
        kind = ("an odd integer" if self.odd else "an integer") if self.integer else "a number"
        if self.above:
            return f"{kind} above {_g(self.lo)} and up to {_g(self.hi)}{self.unit}"
        return f"{kind} from {_g(self.lo)} to {_g(self.hi)}{self.unit}"

    def value(self, text: str) -> float:
        """The number ``text`` says, checked (ValueError naming the range otherwise)."""
        try:
            value: float = int(text) if self.integer else float(text)
        except ValueError:
            value = math.nan
        inside = self.lo < value if self.above else self.lo <= value
        if not (math.isfinite(value) and inside and value <= self.hi):
            sign = " (negative)" if value < 0 <= self.lo else ""
            raise ValueError(f"must be {self.describe()}, got {text!r}{sign}")
        if self.odd and value % 2 == 0:
            raise ValueError(f"must be {self.describe()}, got {text!r} (even)")
        return value

    def __call__(self, text: str) -> float:
        try:
            return self.value(text.strip())
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None


def duration_s() -> Number:
    """A ``--duration``/``--timeout``: seconds, above 0 and finite (up to a month)."""
    return Number(0.0, MAX_DURATION_S, above=True, unit="s")


def seed() -> Number:
    """A ``--seed``: a non-negative integer every simulated device's generator takes."""
    return Number(0, MAX_SEED, integer=True)


def stop_ranges() -> NumberList:
    """A flight's ``--stops``: hover ranges in metres, above 0 and up to 5 km, at most 50."""
    return NumberList(Number(0.0, MAX_STOP_RANGE_M, above=True, unit="m"), 50)


class NumberList:
    """An argparse type: comma-separated numbers, each a :class:`Number` ``each``, at most
    ``max_count`` of them."""

    def __init__(self, each: Number, max_count: int) -> None:
        self.each, self.max_count = each, max_count
        self.__name__ = "list"

    def __call__(self, text: str) -> tuple[float, ...]:
        words = [w.strip() for w in text.split(",") if w.strip()]
        if not 1 <= len(words) <= self.max_count:
            raise argparse.ArgumentTypeError(
                f"must be 1 to {self.max_count} comma-separated numbers, got {text!r}"
            )
        try:
            return tuple(self.each.value(w) for w in words)
        except ValueError as exc:
            where = f" in {text!r}" if len(words) > 1 else ""
            raise argparse.ArgumentTypeError(f"each {exc}{where}") from None


class Size:
    """An argparse type: ``WxH`` in pixels, each side from ``lo`` to ``hi``."""

    def __init__(self, lo: int, hi: int = MAX_FRAME_PX) -> None:
        self.lo, self.hi = lo, hi
        self.__name__ = "size"

    def __call__(self, text: str) -> tuple[int, int]:
        w, sep, h = text.strip().lower().partition("x")
        try:
            size = (int(w), int(h))
        except ValueError:
            size = (0, 0)
        if not sep or not all(self.lo <= v <= self.hi for v in size):
            raise argparse.ArgumentTypeError(
                f"must be WxH in pixels, {self.lo} to {self.hi} each, got {text!r}"
            )
        return size
