"""The recording options that ``record``, ``hil``, ``demo`` and ``gui`` share."""

from __future__ import annotations

import argparse
import dataclasses
from typing import Any

from snrmon.limits import COMPRESSION_CHOICES, DEFAULT_COMPRESSION


def add_compression_option(p: argparse.ArgumentParser) -> None:
    """``--compression``: the recorded frames' lossless filter (None when not given: the
    session config's ``compression`` key, else the default)."""
    p.add_argument(
        "--compression",
        choices=COMPRESSION_CHOICES,
        default=None,
        metavar="|".join(COMPRESSION_CHOICES),
        help=f"the recorded frames' lossless filter (default: {DEFAULT_COMPRESSION}, or the "
        "session config's compression key; docs/session-format.md)",
    )


def with_compression(config: Any, choice: str | None) -> Any:
    """The session config with ``--compression``'s choice, when one was given."""
    return config if choice is None else dataclasses.replace(config, compression=choice)
