"""What a real X screen shows, pixel by pixel: the screen's root window grabbed by a Qt process
of its own on the xcb platform (the test process runs Qt offscreen), so a test reads the colours
the console painted where its status file says a widget is.

``python -m tests.gui.screen_grab`` (DISPLAY set) answers each line ``PATH`` on its standard
input with the screen saved to PATH as PNG, then ``ok``: one process for a module's grabs.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


class ScreenGrabber:
    """The screen of ``display`` on demand (:meth:`grab`), from one helper process."""

    def __init__(self, display: str, folder: Path) -> None:
        env = {
            **os.environ,
            "DISPLAY": display,
            "QT_QPA_PLATFORM": "xcb",
            "PYTHONPATH": str(REPO),
        }
        self.folder = folder
        self.count = 0
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "tests.gui.screen_grab"],
            env=env,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )

    def grab(self):
        """The whole screen now, as a QImage (read with ``pixelColor(x, y)``)."""
        from PySide6.QtGui import QImage

        self.count += 1
        path = self.folder / f"screen-{self.count}.png"
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(f"{path}\n")
        self.proc.stdin.flush()
        answer = self.proc.stdout.readline().strip()
        if answer != "ok":
            _, err = self.proc.communicate(timeout=30)
            raise AssertionError(f"the screen grab failed ({answer!r}): {err}")
        image = QImage(str(path))
        assert not image.isNull(), path
        return image

    def close(self) -> None:
        if self.proc.poll() is None:
            assert self.proc.stdin is not None
            self.proc.stdin.close()
            try:
                self.proc.wait(30)
            finally:
                self.proc.kill()


def colour_at(image, x: int, y: int) -> str:
    """The colour of screen pixel (x, y) of a grab, ``#rrggbb``."""
    return image.pixelColor(x, y).name()


def colours_in(image, rect: list[int]) -> dict[str, int]:
    """How many pixels of each colour a rectangle ``[x, y, w, h]`` of a grab holds."""
    x0, y0, w, h = rect
    counts: dict[str, int] = {}
    for y in range(max(y0, 0), min(y0 + h, image.height())):
        for x in range(max(x0, 0), min(x0 + w, image.width())):
            name = image.pixelColor(x, y).name()
            counts[name] = counts.get(name, 0) + 1
    return counts


def _serve() -> None:
    from PySide6.QtGui import QGuiApplication

    app = QGuiApplication(sys.argv[:1])
    screen = app.primaryScreen()
    for line in sys.stdin:
        path = line.strip()
        if not path:
            continue
        ok = screen.grabWindow(0).save(path, "PNG")
        print("ok" if ok else f"not saved: {path}", flush=True)


if __name__ == "__main__":
    _serve()
