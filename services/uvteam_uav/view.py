"""What the UAV sees, for people: each processed frame drawn with its detections and the localizer's crowds
(:func:`uvteam.vision.annotate.annotate`), served as MJPEG (``[uav].annotate_http``) and written to a
video file (``[uav].annotate_video``).

The node hands over each processed frame (``UavNode.on_processed``, on its vision thread: a slot, newest
wins); a thread of the shell's own waits briefly for the localizer's crowds of that frame (they follow
its detections by a few milliseconds), draws, and hands the picture out. Nothing is drawn while nobody
watches and no file is written."""

from __future__ import annotations

import logging
import threading
from collections import OrderedDict

import numpy as np

from uvteam.messages import Crowds, Detections, Fix
from uvteam.service import LatestSlot, StopFlag
from uvteam.vision.annotate import annotate

__all__ = ["AnnotatedView"]

log = logging.getLogger("uvteam.uav")
CROWDS_WAIT_S = 0.15        # how long a frame waits for its crowds message
KEEP_CROWDS = 64


class AnnotatedView:
    def __init__(self, uav: str, server=None, writer=None) -> None:
        self.uav, self.server, self.writer = uav, server, writer
        self.frames = LatestSlot()
        self._cv = threading.Condition()
        self._crowds: OrderedDict[float, Crowds] = OrderedDict()
        self._ugvs: dict[str, tuple[float, float]] = {}
        self.drawn = 0
        self.with_crowds = 0

    # --- inputs (the node's vision thread; zenoh's threads) -------------------------------------
    def on_processed(self, img: np.ndarray, det: Detections) -> None:
        if self.wanted():
            self.frames.put((img, det))

    def on_crowds(self, _key: str, msg: Crowds) -> None:
        if msg.uav != self.uav:
            return
        with self._cv:
            self._crowds[msg.stamp_s] = msg
            while len(self._crowds) > KEEP_CROWDS:
                self._crowds.popitem(last=False)
            self._cv.notify_all()

    def on_fix(self, _key: str, fix: Fix) -> None:
        with self._cv:
            self._ugvs[fix.vehicle] = (fix.lat_deg, fix.lon_deg)

    def wanted(self) -> bool:
        return self.writer is not None or (self.server is not None and self.server.watchers > 0)

    # --- the drawing thread ------------------------------------------------------------------------
    def crowds_for(self, stamp_s: float, wait_s: float) -> Crowds | None:
        with self._cv:
            self._cv.wait_for(lambda: stamp_s in self._crowds, timeout=wait_s)
            return self._crowds.get(stamp_s)

    def draw_one(self, timeout_s: float) -> np.ndarray | None:
        item = self.frames.take(timeout_s)
        if item is None:
            return None
        img, det = item
        crowds = self.crowds_for(det.stamp_s, CROWDS_WAIT_S)
        with self._cv:
            ugvs = dict(self._ugvs)
        out = annotate(img, det, crowds, ugvs, note="" if crowds is not None else "(no crowds message yet)")
        self.drawn += 1
        self.with_crowds += crowds is not None
        if self.server is not None:
            self.server.publish(out)
        if self.writer is not None:
            try:
                self.writer.write(det.stamp_s, out)
            except OSError as exc:
                log.error("annotated video: %s; no longer written", exc)
                self.writer = None
        return out

    def worker(self, stop: StopFlag) -> None:
        while not stop.is_set():
            try:
                self.draw_one(0.2)
            except Exception:  # a drawing bug must not take the service down: logged, the next frame tried
                log.exception("annotating a frame failed")
                stop.wait(1.0)
