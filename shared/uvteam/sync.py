"""What a service's threads share: a stop flag (set by SIGINT/SIGTERM or the caller) and a newest-wins
slot. No I/O; the signal handlers are installed only when asked, from the main thread."""

from __future__ import annotations

import signal
import threading
from typing import Any

__all__ = ["StopFlag", "LatestSlot"]


class StopFlag:
    """Set by SIGINT or SIGTERM (or by the caller); services poll it or wait on it."""

    def __init__(self, install: bool = True) -> None:
        self.event = threading.Event()
        if install and threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                signal.signal(sig, lambda *_: self.event.set())

    def is_set(self) -> bool:
        return self.event.is_set()

    def wait(self, timeout: float) -> bool:
        return self.event.wait(timeout)

    def set(self) -> None:
        self.event.set()


class LatestSlot:
    """One waiting item; a newer one replaces it (counted in ``dropped``): work never falls behind."""

    def __init__(self) -> None:
        self._cv = threading.Condition()
        self._item: Any = None
        self.dropped = 0

    def put(self, item: Any) -> None:
        with self._cv:
            if self._item is not None:
                self.dropped += 1
            self._item = item
            self._cv.notify()

    def take(self, timeout_s: float) -> Any:
        """The waiting item (None when none came within ``timeout_s``; 0 does not wait)."""
        with self._cv:
            if self._item is None and timeout_s > 0:
                self._cv.wait(timeout_s)
            item, self._item = self._item, None
            return item
