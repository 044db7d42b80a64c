"""A real X display for what must be measured or seen in a real window: an Xvfb server of a
given screen size, started and stopped by its caller (the real-window benchmark, the screenshot
tool)."""

from __future__ import annotations

import os
import select
import shutil
import subprocess
from dataclasses import dataclass

START_TIMEOUT_S = 30.0


class XvfbError(RuntimeError):
    """Xvfb is not installed, or did not start."""


@dataclass
class Xvfb:
    """A running Xvfb server: its display (":N") and process."""

    display: str
    proc: subprocess.Popen
    read_fd: int

    def stop(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(10)
        os.close(self.read_fd)

    def __enter__(self) -> Xvfb:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def start_xvfb(size: str) -> Xvfb:
    """An Xvfb server with one 24-bit screen of ``size`` ("WxH") pixels, accepting connections.

    Xvfb chooses a free display number and writes it to a pipe once it is ready (``-displayfd``);
    the pipe stays open while the server runs, since Xvfb writes to it again when it resets (its
    last client gone) and would die of SIGPIPE on a closed one."""
    if shutil.which("Xvfb") is None:
        raise XvfbError("Xvfb not installed (apt-get install xvfb)")
    read_fd, write_fd = os.pipe()
    proc = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write_fd), "-screen", "0", f"{size}x24", "-nolisten", "tcp"],
        pass_fds=(write_fd,),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    os.close(write_fd)
    ready, _, _ = select.select([read_fd], [], [], START_TIMEOUT_S)
    number = os.read(read_fd, 64).decode().strip() if ready else ""
    if not number:
        proc.kill()
        proc.wait(10)
        os.close(read_fd)
        raise XvfbError(f"Xvfb ({size}) did not report a display within {START_TIMEOUT_S:g} s")
    return Xvfb(f":{number}", proc, read_fd)
