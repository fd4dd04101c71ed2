"""Recordings of a team's bus as MCAP files (https://mcap.dev): what ``uvteam record`` and
``uvteam demo --record`` write and ``uvteam replay`` reads. Foxglove opens them as they are.

What a recording holds:

- every payload as it came, on a channel per key (topic = the zenoh key, ``uvteam/<team>/<vehicle>/<topic>``),
  message encoding ``msgpack``, with the message's schema attached (schema name = the uvteam schema,
  e.g. ``crowds/3``; schema encoding ``jsonschema``: :func:`uvteam.protocol.wire_schema`) and the zenoh
  encoding in the channel's metadata (``zenoh_encoding``). Log time = when the recorder received it;
  publish time = the message's own ``stamp_s`` when it has one; ``sequence`` = arrival order;
- liveliness: ``uvteam/<team>/<vehicle>/alive`` channels (``json``, schema ``uvteam.alive``), one
  message per change, so a replay knows when a vehicle was lost;
- for Foxglove's Map panel: ``foxglove/<vehicle>/location`` (``foxglove.LocationFix``, json) per fix,
  and ``foxglove/<localizer>/crowds`` (``foxglove.GeoJSON``, json) per crowds message
  (:mod:`uvteam.formats.foxglove`);
- metadata ``uvteam`` (team, recorder, uvteam version) and, when known, ``uvteam.config.<id>`` with a
  vehicle's config TOML (``uvteam replay --localizer`` runs the localizer on it).

Camera frames are recorded only when asked (they are megabytes each), as ``uvteam tap`` does.
"""

from __future__ import annotations

import json
import logging
import math
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import msgpack

from .. import keys, messages, protocol
from ..errors import MessageError
from ..formats import foxglove

__all__ = ["Record", "Recording", "McapRecorder", "read_recording", "attach_zenoh", "attach_in_memory",
           "ns_of", "s_of", "RAW_MESSAGE_ENCODING", "ALIVE_SCHEMA", "record_topics"]

log = logging.getLogger(__name__)
RAW_MESSAGE_ENCODING = "msgpack"
ALIVE = "alive"
ALIVE_SCHEMA = {"title": "uvteam.alive", "description": "A vehicle's liveliness token appeared (true) or went (false)",
                "type": "object", "required": ["vehicle", "alive"], "additionalProperties": False,
                "properties": {"vehicle": {"type": "string"}, "alive": {"type": "boolean"}}}


def ns_of(t_s: float) -> int:
    """UNIX seconds -> integer nanoseconds, exactly enough that :func:`s_of` gives back the same float."""
    sec = math.floor(t_s)
    return int(sec) * 1_000_000_000 + int(round((t_s - sec) * 1e9))


def s_of(t_ns: int) -> float:
    return t_ns / 1e9


def _version() -> str:
    try:
        from importlib.metadata import version  # noqa: PLC0415

        return version("uvteam")
    except Exception:  # running from a source tree that is not installed
        return "unknown"


def _schema_of(encoding: str, key: str) -> type | None:
    """The message type a payload claims: zenoh's encoding suffix, else the key's topic."""
    _, _, name = encoding.partition(";")
    for cls in protocol.TOP_LEVEL:
        if cls.SCHEMA == name:
            return cls
    return None if name else messages.BY_TOPIC.get(keys.topic_of(key) or "")


def _encoding_in(raw: bytes) -> str:
    """The encoding a payload would have had on zenoh (for buses that carry none: the in-memory one)."""
    try:
        schema = msgpack.unpackb(raw, raw=False)["schema"]
        return f"{messages.ENCODING};{schema}" if isinstance(schema, str) else messages.ENCODING
    except Exception:  # not our envelope: recorded as it came
        return messages.ENCODING


class McapRecorder:
    """Writes what it is handed to an MCAP file; safe to call from zenoh's threads.

    ``clock``: the log time of each message (UNIX seconds; the host clock, or a simulated one)."""

    def __init__(self, output: str | Path | IO[bytes], team: str, *, foxglove_channels: bool = True,
                 clock: Callable[[], float] = time.time, recorder: str = "uvteam record") -> None:
        from mcap.writer import Writer  # noqa: PLC0415

        self.team = keys.check_id("team", team)
        self.clock, self.foxglove_channels = clock, foxglove_channels
        self._own = not hasattr(output, "write")
        self._stream = open(output, "wb") if self._own else output   # noqa: SIM115 (closed in close())
        self._w = Writer(self._stream)
        self._w.start(profile="", library=f"uvteam {_version()}")
        self._w.add_metadata("uvteam", {"team": team, "recorder": recorder, "uvteam_version": _version(),
                                        "started_unix_s": repr(self.clock())})
        self._lock = threading.Lock()
        self._schemas: dict[str, int] = {}
        self._channels: dict[tuple[str, str], int] = {}
        self._seq = 0
        self.roles: dict[str, str] = {}
        self.counts: Counter = Counter()
        self.bytes = 0
        self.undecodable = 0
        self._closed = False

    # --- schemas and channels ---------------------------------------------------------------------
    def _schema(self, name: str, schema: dict) -> int:
        sid = self._schemas.get(name)
        if sid is None:
            sid = self._schemas[name] = self._w.register_schema(name, "jsonschema", json.dumps(schema).encode())
        return sid

    def _channel(self, topic: str, message_encoding: str, schema_name: str | None, schema: dict | None,
                 metadata: dict[str, str] | None = None) -> int:
        cid = self._channels.get((topic, message_encoding + (metadata or {}).get("zenoh_encoding", "")))
        if cid is None:
            sid = self._schema(schema_name, schema) if schema_name else 0
            cid = self._w.register_channel(topic, message_encoding, sid, metadata or {})
            self._channels[(topic, message_encoding + (metadata or {}).get("zenoh_encoding", ""))] = cid
        return cid

    def _add(self, cid: int, data: bytes, log_ns: int, pub_ns: int) -> None:
        self._w.add_message(cid, log_time=log_ns, data=data, publish_time=pub_ns, sequence=self._seq & 0xFFFFFFFF)
        self._seq += 1
        self.bytes += len(data)

    # --- what is recorded -------------------------------------------------------------------------
    def add_payload(self, key: str, raw: bytes, encoding: str | None = None) -> None:
        """One payload as it came on ``key`` (``encoding``: zenoh's; None: read off the payload)."""
        enc = encoding or _encoding_in(raw)
        cls = _schema_of(enc, key)
        msg = None
        if cls is not None:
            try:
                msg = messages.decode(cls, raw)
            except MessageError:
                msg = None
        with self._lock:
            if self._closed:
                return
            log_ns = ns_of(self.clock())
            stamp = getattr(msg, "stamp_s", None)
            pub_ns = ns_of(stamp) if stamp is not None else log_ns
            cid = self._channel(key, RAW_MESSAGE_ENCODING, cls.SCHEMA if cls else None,
                                protocol.wire_schema(cls) if cls else None, {"zenoh_encoding": enc})
            self._add(cid, bytes(raw), log_ns, pub_ns)
            self.counts[keys.topic_of(key) or key] += 1
            if cls is not None and msg is None:
                self.undecodable += 1
            if msg is not None and self.foxglove_channels:
                self._foxglove(key, msg, log_ns, pub_ns)

    def _foxglove(self, key: str, msg: Any, log_ns: int, pub_ns: int) -> None:
        vehicle = keys.vehicle_of(key) or "?"
        if isinstance(msg, messages.Status):
            self.roles[msg.vehicle] = msg.service
        elif isinstance(msg, messages.Detections) and keys.topic_of(key) == "detections":
            self.roles.setdefault(vehicle, "uav")
        elif isinstance(msg, messages.Fix) and keys.topic_of(key) == "fix":
            cid = self._channel(f"foxglove/{vehicle}/location", "json", foxglove.LOCATION_FIX,
                                foxglove.SCHEMAS[foxglove.LOCATION_FIX])
            self._add(cid, json.dumps(foxglove.location_fix(msg, self.roles.get(vehicle, ""))).encode(), log_ns, pub_ns)
        elif isinstance(msg, messages.Crowds):
            cid = self._channel(f"foxglove/{vehicle}/crowds", "json", foxglove.GEOJSON, foxglove.SCHEMAS[foxglove.GEOJSON])
            self._add(cid, json.dumps(foxglove.crowds_geojson(self.team, msg)).encode(), log_ns, pub_ns)

    def add_alive(self, key: str, alive: bool) -> None:
        """A liveliness token of ``key`` (``uvteam/<team>/<vehicle>/alive``) appeared or went."""
        with self._lock:
            if self._closed:
                return
            log_ns = ns_of(self.clock())
            cid = self._channel(key, "json", ALIVE_SCHEMA["title"], ALIVE_SCHEMA)
            self._add(cid, json.dumps({"vehicle": keys.vehicle_of(key) or key, "alive": bool(alive)}).encode(),
                      log_ns, log_ns)
            self.counts[ALIVE] += 1

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        with self._lock:
            self._w.add_metadata(name, data)

    def add_config(self, vehicle: str, toml_text: str) -> None:
        """A vehicle's config, so a replay can run its service on it."""
        self.add_metadata(f"uvteam.config.{vehicle}", {"toml": toml_text})

    @property
    def messages(self) -> int:
        return sum(self.counts.values())

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            self._w.finish()
            if self._own:
                self._stream.close()

    def __enter__(self) -> "McapRecorder":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


# --- reading -------------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Record:
    """One recorded payload or liveliness change, in arrival order."""

    key: str
    log_time_ns: int
    data: bytes               # the msgpack payload as it came; for liveliness the JSON change
    encoding: str             # zenoh's encoding ("application/msgpack;fix/2"); "alive" for liveliness
    sequence: int

    @property
    def log_time_s(self) -> float:
        return s_of(self.log_time_ns)

    @property
    def alive(self) -> bool | None:
        return json.loads(self.data)["alive"] if self.encoding == ALIVE else None


@dataclass
class Recording:
    records: list[Record]
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)

    @property
    def team(self) -> str | None:
        return self.metadata.get("uvteam", {}).get("team")

    def config_toml(self, vehicle: str) -> str | None:
        return self.metadata.get(f"uvteam.config.{vehicle}", {}).get("toml")


def read_recording(path: str | Path) -> Recording:
    """The payloads and liveliness changes of an MCAP recording, in arrival order (the Foxglove
    channels are left out: they are derived)."""
    from mcap.reader import make_reader  # noqa: PLC0415

    out: list[Record] = []
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        meta = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
        for _schema, channel, msg in reader.iter_messages(log_time_order=False):
            if channel.message_encoding == RAW_MESSAGE_ENCODING:
                enc = channel.metadata.get("zenoh_encoding", messages.ENCODING)
            elif channel.message_encoding == "json" and channel.topic.endswith("/" + ALIVE):
                enc = ALIVE
            else:
                continue
            out.append(Record(channel.topic, msg.log_time, msg.data, enc, msg.sequence))
    out.sort(key=lambda r: (r.log_time_ns, r.sequence))
    return Recording(out, meta)


# --- attaching a recorder to a bus ---------------------------------------------------------------
def record_topics(frames: bool) -> tuple[str, ...]:
    return tuple(t for t in keys.TOPICS if t != "frame" or frames)


def attach_zenoh(session: Any, team: str, recorder: McapRecorder, *, frames: bool = False) -> list[Any]:
    """Subscribe ``recorder`` to every key of ``team`` on a zenoh session (one subscription per topic, so
    frames are not routed here unless ``frames``) and to its liveliness tokens. Returns the
    subscribers (undeclare them, or close the session, before closing the recorder)."""
    import zenoh  # noqa: PLC0415

    def on_sample(sample) -> None:
        try:
            recorder.add_payload(str(sample.key_expr), sample.payload.to_bytes(), str(sample.encoding))
        except Exception:  # a recorder bug must not kill zenoh's thread
            log.exception("recording %s failed", sample.key_expr)

    def on_alive(sample) -> None:
        recorder.add_alive(str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT)

    subs = [session.declare_subscriber(keys.all_vehicles(team, t), on_sample) for t in record_topics(frames)]
    subs.append(session.liveliness().declare_subscriber(keys.alive_all(team), on_alive, history=True))
    return subs


def attach_in_memory(hub: Any, team: str, recorder: McapRecorder, *, frames: bool = False) -> None:
    """The same on an :class:`uvteam.bus.InMemoryBus` hub (the experiment's): every payload as published."""
    from ..bus import InMemoryBus  # noqa: PLC0415

    class _Raw(InMemoryBus):
        def _deliver(self, key: str, raw: bytes, cls: type, handler) -> None:
            handler(key, raw)

    tap = _Raw(hub)
    for t in record_topics(frames):
        tap.subscribe(keys.all_vehicles(team, t), object, lambda k, raw: recorder.add_payload(k, raw))
    tap.watch_alive(keys.alive_all(team), recorder.add_alive)
