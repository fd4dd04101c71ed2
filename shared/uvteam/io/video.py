"""Frame sources for the service shells: cameras, streams and files, each frame with its capture time.

Sources (``open_source(url)``), each giving ``(stamp_s, frame_bgr)`` with the capture time:

- ``device:N`` or ``N``: a camera device (V4L2 on Linux), stamped with the host clock at grab;
- ``rtsp://...``, ``http(s)://...``, ``udp://...``: a network stream through FFmpeg, stamped at grab;
- ``gst:<pipeline>``: a GStreamer pipeline ending in appsink (when OpenCV was built with GStreamer);
- a file path: a video file, stamped from its own timeline (start time + position), optionally paced
  at the file's frame rate so a recording plays like a camera.

Frames from the simulator arrive over the bus instead (key ``.../frame``); the UAV service subscribes
to them itself. This module is I/O for the shells; the detectors never see where a frame came from.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from pathlib import Path

import cv2
import numpy as np

from ..frames import FrameError

__all__ = ["FrameSource", "open_source"]


class FrameSource:
    """A cv2.VideoCapture with capture times. ``read()`` -> (stamp_s, frame) or None at the end / on error."""

    def __init__(self, cap: cv2.VideoCapture, url: str, *, is_file: bool, pace: bool,
                 clock: Callable[[], float] = time.time, sleep: Callable[[float], None] = time.sleep) -> None:
        self.cap, self.url, self.is_file, self.pace = cap, url, is_file, pace
        self.clock, self.sleep = clock, sleep
        self.fps = float(cap.get(cv2.CAP_PROP_FPS) or 0.0)
        self._t0: float | None = None
        self.frames = 0

    def read(self) -> tuple[float, np.ndarray] | None:
        if not self.cap.grab():
            return None
        grabbed = self.clock()
        if self.is_file:
            pos_s = (self.frames / self.fps) if self.fps > 0 else float(self.cap.get(cv2.CAP_PROP_POS_MSEC)) / 1000.0
            if self._t0 is None:
                self._t0 = grabbed - pos_s
            stamp = self._t0 + pos_s
            if self.pace and stamp > self.clock():
                self.sleep(stamp - self.clock())
        else:
            stamp = grabbed
        ok, img = self.cap.retrieve()
        if not ok or img is None:
            return None
        self.frames += 1
        if img.ndim == 2:
            img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
        return stamp, img

    def stream(self, stop) -> Iterator[tuple[float, np.ndarray]]:
        """(stamp_s, frame) until the source ends or ``stop`` (anything with ``is_set()``) is set."""
        while not stop.is_set():
            got = self.read()
            if got is None:
                return
            yield got

    def close(self) -> None:
        self.cap.release()

    def __enter__(self) -> "FrameSource":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def open_source(url: str, *, pace: bool = True, clock: Callable[[], float] = time.time) -> FrameSource:
    """Open a camera device, stream, GStreamer pipeline or video file (see the module docstring)."""
    u = url.strip()
    if u.startswith("device:") or u.isdigit():
        idx = int(u.split(":", 1)[1] if u.startswith("device:") else u)
        cap, is_file = cv2.VideoCapture(idx), False
    elif u.startswith("gst:"):
        cap, is_file = cv2.VideoCapture(u[4:], cv2.CAP_GSTREAMER), False
    elif "://" in u:
        cap, is_file = cv2.VideoCapture(u, cv2.CAP_FFMPEG), False
    else:
        if not Path(u).is_file():
            raise FrameError(f"frame source {url!r}: no such file")
        cap, is_file = cv2.VideoCapture(u), True
    if not cap.isOpened():
        raise FrameError(f"frame source {url!r} could not be opened")
    return FrameSource(cap, u, is_file=is_file, pace=pace, clock=clock)
