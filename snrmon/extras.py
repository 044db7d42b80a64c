"""The optional parts of snrmon and what a command says when one is missing.

``pip install snrmon`` is the library and the command line. The console (``gui``: PySide6 and
pyqtgraph) and a campaign's cluster and Parquet tables (``campaign``: Dask and pyarrow) are
extras; a command that needs one that is not installed stops before any work with one line
naming what to install (exit 2, bad input: the installation, not the data, is what is wrong).
"""

from __future__ import annotations

import importlib

from snrmon.cli import UsageError

EXTRAS: dict[str, tuple[str, ...]] = {
    "gui": ("PySide6", "pyqtgraph"),
    "campaign": ("dask", "distributed", "pyarrow"),
    "mavlink": ("pymavlink",),
    "flightlogs": ("pyulog", "pyubx2"),
}


class MissingExtraError(UsageError):
    """A command needs an optional part of snrmon that is not installed."""


def require(extra: str, what: str) -> None:
    """Raise :class:`MissingExtraError` unless every module of ``extra`` imports.

    ``what`` says what needs it ("the console", "a campaign"), for the message."""
    for module in EXTRAS[extra]:
        try:
            importlib.import_module(module)
        except ImportError as exc:
            raise MissingExtraError(
                f"{what} needs {module}, which is not installed: "
                f"pip install 'snrmon[{extra}]' ({exc})"
            ) from None
