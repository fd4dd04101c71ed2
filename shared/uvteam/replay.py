"""A recorded run through a fresh localizer: does today's code give the crowds the team reported?

:func:`replay_localizer` drives a :class:`uvteam.nodes.localizer.LocalizerNode` (the service's own
class, over an in-memory bus) with a recording's fixes, plans, liveliness changes and detections, in
the order they were recorded, on a clock that reads each record's log time. The localizer processes a
frame when it can, not every frame (the newest wins when it falls behind), so the recorded crowds
messages say which frames it processed: at each, the replay processes the detections of that frame
with what had arrived before, and compares the message it publishes with the recorded one, byte for
byte.

A recording of the in-memory experiment (one thread, simulated time) has the localizer's own order of
arrival, and is reproduced exactly. A recording of live processes is the recorder's view: a fix that
reached the localizer a millisecond before a frame's processing, and the recorder a millisecond after
it (or the other way round), changes that frame's inputs; such frames are counted, not hidden.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from . import keys, messages
from .bus import InMemoryBus
from .config import LocalizerServiceConfig, VehicleConfig
from .errors import MessageError
from .io.recording import ALIVE, Recording
from .nodes.localizer import LocalizerNode

__all__ = ["ReplayReport", "replay_localizer", "localizer_config_for"]

M_PER_DEG_LAT = 111_320.0   # near enough to compare two estimates of one crowd
PENDING_FRAMES = 64          # detections kept waiting for the crowds message that says they were processed


@dataclass
class ReplayReport:
    localizer: str
    recorded: int = 0                  # crowds messages of this localizer in the recording
    reproduced: int = 0                # ... replayed byte for byte
    differed: list[tuple[float, bytes, bytes]] = field(default_factory=list)   # (frame stamp, recorded, replayed)
    no_detections: int = 0             # crowds whose frame's detections are not in the recording
    rejected: int = 0                  # inputs the localizer refused (as it would live)

    @property
    def exact(self) -> bool:
        return self.recorded > 0 and self.reproduced == self.recorded

    def gaps_m(self) -> list[float]:
        """For the messages that differ: how far apart each crowd (same id in both) is, metres."""
        out = []
        for _stamp, a, b in self.differed:
            if not b:
                continue
            got = {c.crowd_id: c for c in messages.decode(messages.Crowds, b).crowds}
            for c in messages.decode(messages.Crowds, a).crowds:
                d = got.get(c.crowd_id)
                if d is not None:
                    out.append(math.hypot((c.lat_deg - d.lat_deg) * M_PER_DEG_LAT,
                                          (c.lon_deg - d.lon_deg) * M_PER_DEG_LAT * math.cos(math.radians(c.lat_deg))))
        return out

    def summary(self) -> str:
        gaps = sorted(self.gaps_m())
        apart = (f"; where they differ, crowds are {gaps[len(gaps) // 2]:.3f} m apart (median), {gaps[-1]:.3f} m at most"
                 if gaps else "")
        return (f"localizer {self.localizer}: {self.recorded} crowds messages recorded, {self.reproduced} reproduced "
                f"byte for byte, {len(self.differed)} differ, {self.no_detections} without their detections; "
                f"{self.rejected} inputs refused{apart}")


class _Clock:
    def __init__(self) -> None:
        self.t_s = 0.0

    def __call__(self) -> float:
        return self.t_s


def localizer_config_for(rec: Recording, localizer: str | None = None) -> VehicleConfig:
    """The localizer's config: the one the recording carries, else the shipped defaults for the team,
    localizer and UAV its crowds messages name, with the vehicles that publish plans as its UGVs."""
    from .config import vehicle_config_from_dict  # noqa: PLC0415
    from .io.files import tomllib  # noqa: PLC0415

    crowds = [r for r in rec.records if keys.topic_of(r.key) == "crowds" and r.encoding != ALIVE
              and (localizer is None or keys.vehicle_of(r.key) == localizer)]
    if not crowds:
        raise ValueError("the recording has no crowds messages" + (f" from {localizer}" if localizer else ""))
    loc = keys.vehicle_of(crowds[0].key)
    text = rec.config_toml(loc)
    if text is not None:
        return vehicle_config_from_dict(tomllib.loads(text), f"<recording: uvteam.config.{loc}>")
    first = messages.decode(messages.Crowds, crowds[0].data)
    team = crowds[0].key.split("/")[1]
    ugvs = tuple(sorted({keys.vehicle_of(r.key) for r in rec.records if keys.topic_of(r.key) == "plan"}))
    return VehicleConfig(team, loc, "localizer", localizer=LocalizerServiceConfig(uav=first.uav, ugvs=ugvs))


def replay_localizer(rec: Recording, cfg: VehicleConfig) -> ReplayReport:
    """Run ``cfg``'s localizer over ``rec`` and compare its crowds with the recorded ones."""
    hub = InMemoryBus()
    clock = _Clock()
    node = LocalizerNode(cfg, InMemoryBus(hub), clock)
    node.start()
    out: list[bytes] = []

    class _Capture(InMemoryBus):
        def _deliver(self, key: str, raw: bytes, cls: type, handler) -> None:
            handler(key, raw)

    out_key = keys.key(cfg.team, cfg.id, "crowds")
    _Capture(hub).subscribe(out_key, object, lambda _k, raw: out.append(raw))
    report = ReplayReport(cfg.id)
    pending: dict[float, messages.Detections] = {}
    early: dict[float, bytes] = {}     # crowds that reached the recorder before their frame's detections
    det_key = keys.key(cfg.team, cfg.localizer.uav, "detections")

    def process(det: messages.Detections, recorded: bytes) -> None:
        out.clear()
        node.process(det)
        got = out[-1] if out else b""
        if got == recorded:
            report.reproduced += 1
        else:
            report.differed.append((det.stamp_s, recorded, got))

    for r in rec.records:
        clock.t_s = r.log_time_s
        if r.encoding == ALIVE:
            (hub.declare_alive if r.alive else hub.drop_alive)(r.key)
            continue
        topic = keys.topic_of(r.key)
        if topic in ("fix", "plan"):
            hub.put_raw(r.key, r.data)
        elif r.key == det_key:
            try:
                det = messages.decode(messages.Detections, r.data)
            except MessageError:
                continue
            if det.stamp_s in early:
                process(det, early.pop(det.stamp_s))
                continue
            pending[det.stamp_s] = det
            if len(pending) > PENDING_FRAMES:
                del pending[min(pending)]
        elif r.key == out_key:
            report.recorded += 1
            want = messages.decode(messages.Crowds, r.data)
            det = pending.pop(want.stamp_s, None)
            for s in [s for s in pending if s < want.stamp_s]:   # frames the localizer skipped
                del pending[s]
            if det is None:
                early[want.stamp_s] = r.data
                continue
            process(det, r.data)
    report.no_detections = len(early)
    report.rejected = node.bus.rejected_total
    return report


def first_difference(recorded: bytes, replayed: bytes) -> str:
    """Where two crowds messages differ, for people: the first field that does."""
    if not replayed:
        return "nothing was published"
    a = messages.as_dict(messages.decode(messages.Crowds, recorded))
    b = messages.as_dict(messages.decode(messages.Crowds, replayed))

    def walk(x, y, path: str) -> str | None:
        if isinstance(x, dict) and isinstance(y, dict):
            for k in x:
                d = walk(x[k], y.get(k), f"{path}.{k}")
                if d:
                    return d
            return None
        if isinstance(x, list) and isinstance(y, list):
            if len(x) != len(y):
                return f"{path}: {len(x)} items recorded, {len(y)} replayed"
            for i, (p, q) in enumerate(zip(x, y)):
                d = walk(p, q, f"{path}[{i}]")
                if d:
                    return d
            return None
        if x != y and not (isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y)):
            return f"{path}: recorded {x!r}, replayed {y!r}"
        return None

    return walk(a, b, "crowds") or "the bytes differ (the same values)"
