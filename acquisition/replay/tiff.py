"""TIFF stacks: every 2-D plane of every page a frame, in file order, 16-bit kept.

A stack is stored either as a page per frame (as cameras, ImageJ and OpenCV write it) or as
pages that each hold several planes: samples stored as separate planes of a grey page, or an
SGI ``ImageDepth`` volume (tifffile writes an (N, H, W) array so with
``planarconfig="separate"`` or ``volumetric=True``). Every plane is a frame. A colour page
(RGB, YCbCr, CMYK or palette, or samples interleaved in each pixel) is one frame: its first
channel.

Uncompressed frames stored one after the other (every page's data in final form, each page's
data where the previous one's ends) are memory-mapped; any other file is decoded one page at a
time, each page once (OpenCV reads the compressions tifffile decodes only with the optional
imagecodecs package).

A file cut short (a copy interrupted, a card pulled) is found by what it says it holds beside
what it holds: the frames its metadata declares (ImageJ's ``images=``, tifffile's ``shape``),
the page chain's last link pointing past the end, a page whose data the file does not hold
whole. It is read to its last whole frame with a warning naming the file, the frame it breaks
at and the frames read; a file with no whole frame is a ``ValueError`` naming the file and the
frame it breaks at. A page of several planes that is compressed or tiled is decoded whole or not
at all: the frames before it are read.
"""

from __future__ import annotations

import logging
import math
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

log = logging.getLogger(__name__)

# Photometric interpretations whose samples are the channels of one colour frame (TIFF 6.0,
# tag 262: 2 RGB, 3 palette, 5 separated/CMYK, 6 YCbCr).
_COLOUR = frozenset({2, 3, 5, 6})

# Bytes of pages per OpenCV call in the fallback: each call walks (and decodes) from page 0, so
# fewer, larger calls; bounded so that a long MWIR stack is not read into memory whole.
_CV_CHUNK_BYTES = 256 * 2**20


class BrokenStackError(ValueError):
    """The file does not hold frame ``frame`` whole; the ``read`` frames before it were read."""

    def __init__(self, path: Path, frame: int, read: int, why: str, cut: bool = True) -> None:
        self.frame = frame
        self.read = read
        what = "cut short" if cut else "damaged"
        if frame == 0:
            done = "no whole frame"
        elif read == 0:
            done = (
                f"frames 0-{frame - 1} share its page, decoded whole or not at all: no frame read"
            )
        elif read == frame:
            done = f"read its {read} whole frame" + ("s" if read > 1 else "")
        else:
            done = f"read the {read} frames of the pages before it"
        super().__init__(f"{path}: the file is {what} in frame {frame} ({why}): {done}")


def _read_to(broken: BrokenStackError) -> None:
    """Warn of a break after whole frames; refuse one with none before it."""
    if broken.read == 0:
        raise broken
    log.warning("%s", broken)


def _channels_are_colour(page) -> bool:
    """Whether the page's samples are the channels of one frame, not frames of their own."""
    return page.axes.endswith("S") or int(page.photometric) in _COLOUR


def _channels(page) -> int:
    """The colour channels of each of the page's frames (1 for grey)."""
    return int(page.samplesperpixel) if _channels_are_colour(page) else 1


def _planes(page) -> int:
    """The frames one page holds: every axis but rows, columns and colour channels."""
    colour = _channels_are_colour(page)
    return math.prod(
        length
        for axis, length in zip(page.axes, page.shape, strict=True)
        if axis not in "YX" and not (axis == "S" and colour)
    )


def _frame_size(page) -> tuple[int, int]:
    return int(page.imagelength), int(page.imagewidth)


def _page_frames(page) -> np.ndarray:
    """The page's frames (k, H, W): colour keeps its first channel."""
    image = page.asarray()
    if "S" in page.axes and _channels_are_colour(page):
        image = np.take(image, 0, axis=page.axes.index("S"))
    return image.reshape(-1, *_frame_size(page))


def _chain_cut(tif) -> bool:
    """Whether the last page tifffile found links to a next page (so the chain broke: the link
    points past the end of the file or at bytes that are not a page)."""
    fmt = tif.tiff
    fh = tif.filehandle
    at = tif.pages[-1].offset
    fh.seek(at)
    count = fh.read(fmt.tagnosize)
    if len(count) < fmt.tagnosize:
        return True
    fh.seek(at + fmt.tagnosize + struct.unpack(fmt.tagnoformat, count)[0] * fmt.tagsize)
    link = fh.read(fmt.offsetsize)
    return len(link) < fmt.offsetsize or struct.unpack(fmt.offsetformat, link)[0] != 0


def _declared(tif, size: tuple[int, int], channels: int) -> int | None:
    """The frames the file's metadata says it holds (ImageJ's or tifffile's), None without;
    ``channels`` the colour channels of each frame (1 for grey)."""
    if tif.is_imagej and isinstance(tif.imagej_metadata, dict):
        images = tif.imagej_metadata.get("images")
        return int(images) if isinstance(images, int) and images > 0 else None
    if not (tif.is_shaped and tif.shaped_metadata):
        return None
    frame_values = size[0] * size[1] * channels
    total = 0
    for entry in tif.shaped_metadata:
        values = math.prod(entry.get("shape") or (0,))
        if values == 0 or values % frame_values:
            return None
        total += values // frame_values
    return total


@dataclass(frozen=True)
class _Layout:
    """Where a TIFF's frames are and how many it says it has."""

    size: tuple[int, int]
    planes: tuple[int, ...]  # frames held by each page the chain reaches
    declared: int  # the frames the file says it holds (at least those its pages hold)
    chain_cut: bool
    dtype: np.dtype  # with the file's byte order
    first_byte: int | None  # where frame 0 starts when every frame follows the previous one

    @property
    def held(self) -> int:
        return sum(self.planes)


def _contiguous_start(pages, frame_bytes: int) -> int | None:
    """The byte offset of frame 0 when every page is uncompressed grey frames in final form, each
    page's data where the previous one's ends; else None."""
    start = None
    end = None
    for page in pages:
        if not page.is_final or page.dtype is None or _channels_are_colour(page):
            return None
        first = int(page.dataoffsets[0])
        if end is not None and first != end:
            return None
        start = first if start is None else start
        end = first + _planes(page) * frame_bytes
    return start


def _layout(tif, path: Path) -> _Layout:
    pages = list(tif.pages)
    sizes = sorted({_frame_size(p) for p in pages})
    if len(sizes) != 1:
        raise ValueError(f"{path}: TIFF pages differ in size: {sizes}")
    size = sizes[0]
    planes = tuple(_planes(p) for p in pages)
    dtypes = {p.dtype for p in pages}
    first_byte = None
    dtype = np.dtype(np.uint8)  # only read by the memory map, which needs one known dtype
    if len(dtypes) == 1 and None not in dtypes:
        dtype = np.dtype(dtypes.pop()).newbyteorder(tif.byteorder)
        first_byte = _contiguous_start(pages, size[0] * size[1] * dtype.itemsize)
    return _Layout(
        size=size,
        planes=planes,
        declared=max(sum(planes), _declared(tif, size, _channels(pages[0])) or 0),
        chain_cut=_chain_cut(tif),
        dtype=dtype,
        first_byte=first_byte,
    )


def _missing_frames(layout: _Layout) -> str:
    """Why frames are missing after the ones the file holds ("" when none is)."""
    if layout.declared > layout.held:
        return f"it declares {layout.declared} frames, its pages hold {layout.held}"
    if layout.chain_cut:
        return f"its page chain breaks after page {len(layout.planes) - 1}"
    return ""


def _open_tiff(path: Path):
    import tifffile

    try:
        tif = tifffile.TiffFile(path)
    except (tifffile.TiffFileError, ValueError, EOFError) as exc:
        raise ValueError(f"{path}: not a readable TIFF ({exc})") from None
    if not len(tif.pages):
        tif.close()
        raise ValueError(f"{path}: the TIFF holds no pages")
    return tif


def _mapped(path: Path, layout: _Layout) -> np.ndarray:
    """The whole frames of a contiguous file, memory-mapped (to the cut, with a warning)."""
    assert layout.first_byte is not None
    frame_bytes = layout.size[0] * layout.size[1] * layout.dtype.itemsize
    size_bytes = path.stat().st_size
    whole = min(layout.declared, (size_bytes - layout.first_byte) // frame_bytes)
    why = _missing_frames(layout)
    if whole < layout.declared:
        why = f"it declares {layout.declared} frames, its {size_bytes} bytes hold {whole}"
    if why:
        _read_to(BrokenStackError(path, whole, whole, why))
    return np.memmap(
        path, dtype=layout.dtype, mode="r", offset=layout.first_byte, shape=(whole, *layout.size)
    )


def _page_break(page, path: Path, frame: int, exc: Exception) -> BrokenStackError:
    """The break in a page (its first frame ``frame``) that could not be decoded: the first of
    its planes whose data runs past the end of the file (cut short), else its first (damaged)."""
    size_bytes = path.stat().st_size
    chunks = list(zip(page.dataoffsets, page.databytecounts, strict=True))
    past_end = [i for i, (offset, count) in enumerate(chunks) if offset + count > size_bytes]
    planes = _planes(page)
    plane = 0
    if past_end and planes > 1 and len(chunks) % planes == 0:
        plane = past_end[0] // (len(chunks) // planes)
    why = f"page {page.index}: {type(exc).__name__}: {exc}"
    return BrokenStackError(path, frame + plane, frame, why, cut=bool(past_end))


def _cv_pages(path: Path, start: int, n_pages: int, page_bytes: int) -> Iterator[np.ndarray]:
    """Pages ``start..n_pages-1`` through OpenCV, for compressions tifffile decodes only with
    the optional imagecodecs package (``pip install snrmon[tiff]``; LZW, as OpenCV itself
    writes); chunked, so the cost of OpenCV's walk from page 0 is paid once per chunk, not once
    per page."""
    chunk = max(1, _CV_CHUNK_BYTES // max(page_bytes, 1))
    for first in range(start, n_pages, chunk):
        count = min(chunk, n_pages - first)
        ok, mats = cv2.imreadmulti(str(path), first, count, flags=cv2.IMREAD_UNCHANGED)
        if not ok or len(mats) != count:
            raise ValueError(f"{path}: cannot read TIFF pages {first}-{first + count - 1}")
        for m in mats:
            yield m[..., 0] if m.ndim == 3 else m


def _decoded(tif, path: Path, layout: _Layout) -> Iterator[np.ndarray]:
    """Frames page by page, each page decoded once; to the break, with a warning."""
    tif.pages.cache = False  # a long stack is not kept in memory page by page
    frame = 0
    for i, page in enumerate(tif.pages):
        try:
            frames = _page_frames(page)
        except ValueError as exc:
            if "imagecodecs" in str(exc):
                page_bytes = layout.size[0] * layout.size[1] * layout.dtype.itemsize
                yield from _cv_pages(path, i, len(layout.planes), page_bytes)
                return
            _read_to(_page_break(page, path, frame, exc))
            return
        # A damaged page's data raises its codec's own error (imagecodecs' DeflateError,
        # LzwError, ... derive from RuntimeError), and tifffile an OSError or EOFError when the
        # file ends inside it: each is a page the file does not hold whole.
        except (RuntimeError, OSError, EOFError) as exc:
            _read_to(_page_break(page, path, frame, exc))
            return
        yield from frames
        frame += len(frames)
    why = _missing_frames(layout)
    if why:
        _read_to(BrokenStackError(path, frame, frame, why))


def iter_tiff(path: Path) -> Iterator[np.ndarray]:
    """Frames (H, W) one at a time, each read once (module docstring)."""
    with _open_tiff(path) as tif:
        layout = _layout(tif, path)
        if layout.first_byte is not None:
            yield from _mapped(path, layout)
            return
        yield from _decoded(tif, path, layout)


def load_tiff(path: Path) -> np.ndarray:
    """The whole stack (N, H, W): memory-mapped when its frames are stored uncompressed one after
    the other (as cameras, ImageJ and tifffile write them), else decoded into one array."""
    with _open_tiff(path) as tif:
        layout = _layout(tif, path)
        if layout.first_byte is not None:
            return _mapped(path, layout)
        return np.stack(list(_decoded(tif, path, layout)))
