"""What every command prints for ``--json``: strict JSON, one helper for all of them.

Strict means what RFC 8259 parsers accept: ``NaN`` and infinities are not JSON, so a number that
was not measured or is undefined is written as ``null`` (never a placeholder), and
``allow_nan=False`` makes a value that slipped through an error here rather than a file another
tool cannot read. numpy scalars and arrays, tuples, paths, enums and dataclasses are converted
to their plain JSON form.
"""

from __future__ import annotations

import dataclasses
import enum
import json
import math
import sys
from collections.abc import Mapping
from pathlib import PurePath
from typing import Any, TextIO


def strict(obj: Any) -> Any:
    """``obj`` with every non-finite float replaced by None and numpy/other types made plain."""
    if obj is None or isinstance(obj, bool | str):
        return obj
    # numpy only when it is loaded: no numpy value exists before, and the command line's
    # start does not pay for it.
    np = sys.modules.get("numpy")
    if np is not None:
        if isinstance(obj, np.bool_):
            return bool(obj)
        if isinstance(obj, np.integer):
            return int(obj)
        if isinstance(obj, np.floating):
            obj = float(obj)
        elif isinstance(obj, np.ndarray):
            return strict(obj.tolist())
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        value = float(obj)
        return value if math.isfinite(value) else None
    if isinstance(obj, Mapping):
        return {str(k): strict(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple | set | frozenset):
        return [strict(v) for v in obj]
    if isinstance(obj, enum.Enum):
        return strict(obj.value)
    if isinstance(obj, PurePath):
        return str(obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return strict(dataclasses.asdict(obj))
    raise TypeError(f"cannot write {type(obj).__name__} as JSON: {obj!r}")


def dumps(obj: Any, *, indent: int | None = None) -> str:
    """Strict JSON text of ``obj`` (see the module docstring)."""
    return json.dumps(strict(obj), allow_nan=False, indent=indent)


def emit_json(obj: Any, *, indent: int | None = None, file: TextIO | None = None) -> int:
    """Print ``obj`` as one strict JSON document (one line unless ``indent``); returns 0, the
    exit code of a command whose output this is."""
    print(dumps(obj, indent=indent), file=file or sys.stdout, flush=True)
    return 0
