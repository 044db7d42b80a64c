"""Where ``snrmon characterize`` and ``snrmon psf`` keep their results: beside the recording
(``F.analysis.json``, :mod:`snrmon.acquisition.record.analysis_file`) by default, so the raw
recording keeps its bytes and its modification time; into the recording as an event only when
asked (``--write``); nowhere with ``--no-record``."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_result_options(p: argparse.ArgumentParser, kind: str) -> None:
    """``--write`` and ``--no-record`` for a command whose result is a ``kind`` entry."""
    where = p.add_mutually_exclusive_group()
    where.add_argument(
        "--write",
        action="store_true",
        help=f"add the result to the recording itself as a {kind} event (this changes the "
        "file; default: beside it in FILE.analysis.json)",
    )
    where.add_argument(
        "--no-record",
        action="store_true",
        help="keep the result nowhere (neither beside the recording nor in it)",
    )


def keep_result(args: argparse.Namespace, kind: str, camera: str, payload: dict) -> Path | None:
    """Keep one result as ``args`` asks; the file it went to (None: kept nowhere)."""
    from snrmon import __version__
    from snrmon.output import strict

    if args.no_record:
        return None
    if args.write:
        from snrmon.acquisition.record.reader import append_event

        append_event(args.session, kind, camera=camera, payload=strict(payload))
        return Path(args.session)
    from snrmon.acquisition.record.analysis_file import append_result

    return append_result(
        args.session, kind, camera=camera, payload=strict(payload), software=f"snrmon {__version__}"
    )
