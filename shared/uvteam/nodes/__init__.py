"""The services' logic, one class per service, handed its I/O: a bus (:class:`uvteam.bus.Bus`: zenoh or
the in-memory twin), an autopilot (:class:`uvteam.autopilot.Autopilot`: MAVLink or a fake) and a
clock (a function returning UNIX seconds).

- :class:`.uav.UavNode`: frames -> vision -> detections; its autopilot -> its fix
- :class:`.ugv.UgvNode`: its autopilot -> fix; the team's fixes + the localizer's crowds -> station plan ->
  mission -> autopilot -> plan; forward camera -> people
- :class:`.localizer.LocalizerNode`: detections + fixes + plans -> crowds

The deployed services run them as processes over zenoh (:func:`uvteam.service.run_node`); the experiment
runs exactly these classes over the in-memory bus in simulated time, calling the same phases in a
fixed order. Nothing outside this package re-implements what a service does.

Trust no sender: every handler checks that the key's vehicle, the payload's vehicle and the expected
sender agree; what does not is counted (``spoofed``) and dropped.
"""

from __future__ import annotations

import threading
from collections import Counter

from .. import keys

__all__ = ["STREAM_START_S", "Counts", "sender_ok"]

# An autopilot's streams start one by one, and a camera may run before them: for this long after a
# node first needs one, a missing stream (no height above ground, no GPS_RAW_INT) is the stream
# starting, logged at debug. Longer, it is worth a warning. The data is refused all the same.
STREAM_START_S = 5.0


class Counts:
    """Thread-safe named counters, reported as metrics."""

    def __init__(self, *names: str) -> None:
        self._lock = threading.Lock()
        self._c: Counter = Counter({n: 0 for n in names})

    def add(self, name: str, n: int = 1) -> None:
        with self._lock:
            self._c[name] += n

    def __getitem__(self, name: str) -> int:
        with self._lock:
            return self._c[name]

    def as_dict(self) -> dict[str, float]:
        with self._lock:
            return {k: float(v) for k, v in self._c.items()}


def sender_ok(key: str, payload_vehicle: str, expected: str | None = None) -> bool:
    """The key's vehicle is the payload's (and the expected sender's, when one is expected)."""
    v = keys.vehicle_of(key)
    return v == payload_vehicle and (expected is None or v == expected)
