"""A frame whose pixels are made as the measurement reads them.

:class:`LazyFrame` is a full-frame buffer seen as an array whose indexing (``frame[y0:y1,
x0:x1]``, ``frame[y, x]``, ``frame[None]`` and the index arrays Eq. (4) gathers its box with)
first asks its owner to make the rows and columns it is about to return. Two owners:

- the corrector (:meth:`snrmon.acquisition.engine.frame_correction.FrameCorrector.ensure`): the
  corrected frame, corrected where it is read;
- a recording's row strips (:class:`snrmon.acquisition.record.frame_access.FrameCrops`): the raw
  frame of ``replay --fast``, each strip decompressed the first time a read falls in it.

The tracker and Eq. (4) read only such rectangles near the track, so a frame costs the few
thousand pixels they touch instead of the whole square the next frame may read. Everything else
(shape, dtype) is the buffer's own; a whole-array operation that does not index first would see
pixels not yet made this frame, so the measurement code indexes before it reads (it always has:
it reads windows, never the frame), and code that reads the memory itself (compiled kernels,
whole-frame NumPy) takes :func:`plain` of the region it reads.

:func:`read_box` turns an index into the rectangle it reads (rows, columns; half-open), or
None when it cannot tell (the owner then makes everything it would have).
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

Region = tuple[int, int, int, int]  # rows y0:y1, columns x0:x1, half-open


class PixelMaker(Protocol):
    """What a :class:`LazyFrame` asks of its owner."""

    def ensure(self, region: Region | None) -> None:
        """Make ``region`` (None: all it would make) in the buffer, if not done yet."""


def _span(index: Any, n: int) -> tuple[int, int] | None:
    """The half-open range [a, b) of one axis of length ``n`` that ``index`` reads."""
    if isinstance(index, slice):
        start, stop, step = index.indices(n)
        if step != 1:
            return None
        return start, max(stop, start)
    if isinstance(index, (int, np.integer)):
        i = int(index)
        i = i + n if i < 0 else i
        return (i, i + 1) if 0 <= i < n else None
    if isinstance(index, np.ndarray) and index.dtype.kind in "iu":
        if index.size == 0:
            return 0, 0
        lo, hi = int(index.min()), int(index.max())
        return (lo, hi + 1) if lo >= 0 and hi < n else None
    return None


def read_box(key: Any, shape: tuple[int, ...]) -> Region | None:
    """The rectangle (rows, columns) of the last two axes that ``frame[key]`` reads; None
    when the index is of another kind (a mask, an ellipsis, a list, a missing axis)."""
    if not isinstance(key, tuple) or len(key) != len(shape) or len(shape) < 2:
        return None
    rows = _span(key[-2], shape[-2])
    cols = _span(key[-1], shape[-1])
    if rows is None or cols is None:
        return None
    return rows[0], rows[1], cols[0], cols[1]


def _box2(rows: Any, cols: Any, shape: tuple[int, ...]) -> Region | None:
    """:func:`read_box` of ``frame[rows, cols]`` on a 2-D frame, its plain slices and integers
    without the general path."""
    if type(rows) is slice and type(cols) is slice:
        a, b, da = rows.indices(shape[0])
        c, d, dc = cols.indices(shape[1])
        if da == 1 and dc == 1:
            return a, max(b, a), c, max(d, c)
        return None
    if type(rows) is int and type(cols) is int and 0 <= rows < shape[0] and 0 <= cols < shape[1]:
        return rows, rows + 1, cols, cols + 1
    return read_box((rows, cols), shape)


class LazyFrame(np.ndarray):
    """The corrector's buffer, corrected where it is read (module docstring)."""

    owner: PixelMaker | None = None
    _plain: np.ndarray | None = None  # the buffer itself (plain ndarray), on the frame of of()

    def __array_finalize__(self, obj: Any) -> None:
        self.owner = getattr(obj, "owner", None)
        self._plain = None  # a view of another shape: indexed through ndarray's own path

    def __getitem__(self, key: Any) -> Any:
        owner = self.owner
        if key is None and self.ndim == 2:  # frame[None]: a stack of one, read through later
            return super().__getitem__(key)
        if owner is not None:
            if type(key) is tuple and len(key) == 2 and self.ndim == 2:
                owner.ensure(_box2(key[0], key[1], self.shape))  # the common reads, directly
            else:
                owner.ensure(read_box(key, self.shape))
        plain = self._plain
        if plain is not None:  # the same memory as a plain array: no subclass view to undo
            return plain[key]
        out = super().__getitem__(key)
        return out.view(np.ndarray) if isinstance(out, LazyFrame) else out

    @classmethod
    def of(cls, buffer: np.ndarray, owner: PixelMaker) -> LazyFrame:
        frame = buffer.view(cls)
        frame.owner = owner
        frame._plain = buffer.view(np.ndarray)
        return frame


def plain(frame: np.ndarray, region: Region | None = None) -> np.ndarray:
    """``frame`` as a plain ndarray for code that reads its memory directly (a compiled kernel,
    a whole-frame NumPy operation): a :class:`LazyFrame`'s ``region`` (rows, columns; None: all
    its owner makes) made first; any other array as it is."""
    if type(frame) is not LazyFrame or frame.owner is None:
        return frame
    frame.owner.ensure(region)
    return frame._plain if frame._plain is not None else frame.view(np.ndarray)
