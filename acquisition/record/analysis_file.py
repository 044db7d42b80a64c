"""Analysis results beside a recording: ``F.h5`` -> ``F.analysis.json``.

A recording is raw data: an analysis run afterwards (``snrmon characterize``, ``snrmon psf``)
never changes its bytes or its modification time. Its result goes into one JSON file beside the
recording, a list of entries in the order they were made, each::

    {"kind": "psf_measured" | "target_characterized", "camera": "mwir",
     "utc": "2024-05-14T15:00:00.123456+00:00", "software": "snrmon 0.1.0", "payload": {...}}

with the recording it belongs to named at the top (``recording``: its file name and its
``created_utc`` attribute, which nothing changes after the recording began, so a sidecar copied
beside another recording is refused rather than applied, while a ``gps-import`` into the
recording keeps it). The payload is
what the event of the same kind holds when the result is written into the recording instead
(``--write``; docs/session-format.md). Replays read both: a ``psf_measured`` result carrying the
fitted PSF (``estimate``) is the model's corrected PSF for its camera from the first frame on.
The file is written whole to a temporary name and renamed, so a reader never sees half of it.
"""

from __future__ import annotations

import json
import os
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

FORMAT = "snrmon-analysis"
VERSION = 1
SUFFIX = ".analysis.json"


def sidecar_path(recording: str | os.PathLike) -> Path:
    """``F.analysis.json`` beside ``F.h5``."""
    p = Path(recording)
    return p.with_name(p.stem + SUFFIX)


def _recording_id(recording: Path, created_utc: str | None = None) -> dict:
    if created_utc is None:
        import h5py

        try:
            f = h5py.File(recording, "r", locking=False)
        except OSError:  # a recording left by a crash: its SWMR flags are still set
            f = h5py.File(recording, "r", swmr=True, locking=False)
        with f:
            created_utc = str(f.attrs.get("created_utc", ""))
    return {"name": recording.name, "created_utc": created_utc}


def read_results(recording: str | os.PathLike, *, created_utc: str | None = None) -> list[dict]:
    """The entries of the recording's sidecar, oldest first ([] without one);
    ``created_utc``: the recording's attribute where the caller has it open already.

    Raises:
        ValueError: a sidecar that is not one (the message names it and why), or one that
            belongs to another recording.
    """
    rec = Path(recording)
    side = sidecar_path(rec)
    if not side.is_file():
        return []
    try:
        doc = json.loads(side.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"analysis file {side}: not valid JSON ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ValueError(f"analysis file {side}: not a snrmon analysis file (format)")
    mine = _recording_id(rec, created_utc)
    theirs = doc.get("recording") or {}
    if theirs != mine:
        raise ValueError(
            f"analysis file {side}: it belongs to {theirs.get('name')!r} created "
            f"{theirs.get('created_utc')}, not to {rec.name} created {mine['created_utc']}"
        )
    entries = doc.get("results")
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise ValueError(f"analysis file {side}: results must be a list of objects")
    return entries


def append_result(
    recording: str | os.PathLike,
    kind: str,
    *,
    camera: str = "",
    payload: dict[str, Any],
    software: str = "",
) -> Path:
    """Add one result to the recording's sidecar (made if absent); the sidecar's path.
    ``payload`` must be strict JSON already (a number not measured is None, never NaN);
    ``software`` names what made it (``snrmon`` and its version)."""
    rec = Path(recording)
    entries = read_results(rec)
    entries.append(
        {
            "kind": kind,
            "camera": camera,
            "utc": datetime.now(UTC).isoformat(),
            "software": software,
            "payload": payload,
        }
    )
    doc = {
        "format": FORMAT,
        "version": VERSION,
        "recording": _recording_id(rec),
        "results": entries,
    }
    side = sidecar_path(rec)
    tmp = side.with_name(f".{side.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n")
    os.replace(tmp, side)
    return side
