"""`uvteam record` and `uvteam replay`: a team's bus to an MCAP file, and back.

    uvteam record --team demo --connect tcp/127.0.0.1:7447 -o run.mcap            until Ctrl-C
    uvteam record --team border1 -e tcp/10.0.0.1:7447 -o run.mcap --duration 600 --config deploy/vehicles/localizer.toml
    uvteam replay run.mcap --connect tcp/127.0.0.1:7447                            onto a bus, in real time
    uvteam replay run.mcap -e tcp/127.0.0.1:7447 --speed 4 --team replay1          4x, under another team id
    uvteam replay run.mcap --localizer                                              today's localizer on the
                                                                                   recorded inputs: same crowds?

A recording holds every payload of the team as it came (msgpack, one channel per key, the message's
JSON Schema attached), liveliness changes, and channels Foxglove's Map panel draws (LocationFix per
fix, GeoJSON per crowds message): open it in Foxglove as it is. Camera frames only with --frames.
Details: docs/recording.md.
"""

from __future__ import annotations

import argparse
import logging
import sys
import threading
import time
from pathlib import Path

from uvteam import keys
from uvteam.bus import BusConfig
from uvteam.errors import ConfigError, LinkError
from uvteam.io.files import load_vehicle_config
from uvteam.io.recording import ALIVE, McapRecorder, attach_zenoh, read_recording
from uvteam.io.zenoh_bus import ZenohBus, add_bus_args, bus_config_from_args
from uvteam.service import StopFlag, setup_logging
from uvteam.vocab import is_id

log = logging.getLogger("uvteam.record")
PROGRESS_S = 10.0
CONNECT_WAIT_MS = 15_000


def _client_default(args, wait_ms: int | None = None) -> BusConfig:
    """A laptop tool joins as a client when told where to connect, as `uvteam tap` does."""
    return BusConfig(mode="client" if args.connect and not args.mode else None, connect_timeout_ms=wait_ms)


def record_main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uvteam record", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--team", required=True, help="the team id (uvteam/<team>/...)")
    ap.add_argument("--output", "-o", required=True, metavar="FILE.mcap", help="where the recording goes")
    ap.add_argument("--duration", type=float, default=0.0, help="stop after this many seconds (0 = until Ctrl-C)")
    ap.add_argument("--frames", action="store_true", help="also record camera frames (.../frame; megabytes each)")
    ap.add_argument("--no-foxglove", action="store_true", help="leave out the Foxglove map channels")
    ap.add_argument("--config", action="append", default=[], metavar="FILE",
                    help="a vehicle TOML to keep in the recording (replay --localizer runs on it); repeatable")
    ap.add_argument("--log-level", default="INFO", choices=["DEBUG", "INFO", "WARNING", "ERROR"])
    add_bus_args(ap)
    args = ap.parse_args(argv)
    if not is_id(args.team):
        print(f"uvteam record: --team must be an id (1-32 of A-Z a-z 0-9 _ -), got {args.team!r}", file=sys.stderr)
        return 2
    setup_logging(f"{args.team}/record", args.log_level)
    try:
        configs = [(load_vehicle_config(p), Path(p).read_text(encoding="utf-8")) for p in args.config]
        # a recorder started just before its team's router waits for it a while
        bus = ZenohBus.open(bus_config_from_args(args, _client_default(args, CONNECT_WAIT_MS if args.connect else None)))
    except ConfigError as exc:
        print(f"uvteam record: configuration error: {exc}", file=sys.stderr)
        return 2
    except (LinkError, OSError) as exc:
        print(f"uvteam record: {exc}", file=sys.stderr)
        return 3
    stop = StopFlag()
    with bus:
        try:
            rec = McapRecorder(args.output, args.team, foxglove_channels=not args.no_foxglove)
        except OSError as exc:
            print(f"uvteam record: cannot write {args.output}: {exc}", file=sys.stderr)
            return 2
        for cfg, text in configs:
            rec.add_config(cfg.id, text)
        subs = attach_zenoh(bus.session, args.team, rec, frames=args.frames)
        log.info("recording team %s to %s%s", args.team, args.output, " (with frames)" if args.frames else "")
        t_end = time.monotonic() + args.duration if args.duration > 0 else float("inf")
        next_note = time.monotonic() + PROGRESS_S
        try:
            while not stop.wait(0.2) and time.monotonic() < t_end:
                if time.monotonic() >= next_note:
                    log.info("%d messages, %.1f MB so far", rec.messages, rec.bytes / 1e6)
                    next_note += PROGRESS_S
        finally:
            for s in subs:
                s.undeclare()
            rec.close()
    counts = " ".join(f"{k}={v}" for k, v in sorted(rec.counts.items()))
    log.info("wrote %s: %d messages, %.1f MB (%s)%s", args.output, rec.messages, rec.bytes / 1e6, counts or "nothing",
             f"; {rec.undecodable} did not decode" if rec.undecodable else "")
    return 0


def _retarget(key: str, team: str | None) -> str:
    if team is None:
        return key
    parts = key.split("/")
    return "/".join([parts[0], team, *parts[2:]]) if len(parts) >= 3 and parts[0] == keys.ROOT else key


def replay_main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uvteam replay", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("recording", metavar="FILE.mcap")
    ap.add_argument("--speed", type=float, default=1.0,
                    help="times real time (default 1; 0 = as fast as the bus takes it)")
    ap.add_argument("--team", default=None, help="publish under this team id instead of the recorded one")
    ap.add_argument("--settle-s", type=float, default=1.0,
                    help="wait this long after joining the bus before the first message, so that the bus routes "
                         "to its subscribers (default 1)")
    ap.add_argument("--localizer", action="store_true",
                    help="no bus: run a fresh localizer on the recorded fixes, plans and detections and compare "
                         "its crowds with the recorded ones, byte for byte (exit 1 if any differ)")
    ap.add_argument("--config", metavar="FILE", help="with --localizer: the localizer's TOML (default: the one in "
                                                     "the recording, else the shipped defaults)")
    ap.add_argument("--log-level", default="INFO", choices=["DEBUG", "INFO", "WARNING", "ERROR"])
    add_bus_args(ap)
    args = ap.parse_args(argv)
    if args.team is not None and not is_id(args.team):
        print(f"uvteam replay: --team must be an id, got {args.team!r}", file=sys.stderr)
        return 2
    if args.speed < 0:
        print("uvteam replay: --speed must be >= 0", file=sys.stderr)
        return 2
    setup_logging("replay", args.log_level)
    try:
        rec = read_recording(args.recording)
    except Exception as exc:  # a missing file, or not MCAP (mcap raises several types)
        print(f"uvteam replay: cannot read {args.recording}: {exc}", file=sys.stderr)
        return 2
    if args.localizer:
        if args.log_level != "DEBUG":   # the recorded run's own events (UGVs leaving at its end) are not news here
            logging.getLogger("uvteam.localizer").setLevel(logging.ERROR)
        return _replay_localizer(rec, args.config)
    return _replay_bus(rec, args)


def _replay_localizer(rec, config: str | None) -> int:
    from uvteam.replay import first_difference, localizer_config_for, replay_localizer  # noqa: PLC0415

    try:
        cfg = load_vehicle_config(config) if config else localizer_config_for(rec)
    except (ConfigError, ValueError) as exc:
        print(f"uvteam replay: {exc}", file=sys.stderr)
        return 2
    report = replay_localizer(rec, cfg)
    print(report.summary())
    for stamp, a, b in report.differed[:5]:
        print(f"  frame at {stamp:.3f}: {first_difference(a, b)}")
    return 0 if report.exact else 1


def _replay_bus(rec, args) -> int:
    payloads = [r for r in rec.records]
    if not payloads:
        print("uvteam replay: the recording is empty", file=sys.stderr)
        return 2
    try:
        bus = ZenohBus.open(bus_config_from_args(args, _client_default(args)))
    except ConfigError as exc:
        print(f"uvteam replay: configuration error: {exc}", file=sys.stderr)
        return 2
    except LinkError as exc:
        print(f"uvteam replay: {exc}", file=sys.stderr)
        return 3
    stop = StopFlag()
    tokens: dict[str, object] = {}
    sent = 0
    t_first = payloads[0].log_time_s
    span = payloads[-1].log_time_s - t_first
    log.info("replaying %d records (%.1f s) from %s%s at %s", len(payloads), span, args.recording,
             f" as team {args.team}" if args.team else "", f"{args.speed:g}x" if args.speed else "full speed")
    lock = threading.Lock()
    with bus:
        if stop.wait(max(args.settle_s, 0.0)):
            return 0
        t0 = time.monotonic()
        try:
            for r in payloads:
                if args.speed > 0:
                    wait = t0 + (r.log_time_s - t_first) / args.speed - time.monotonic()
                    if wait > 0 and stop.wait(wait):
                        break
                elif stop.is_set():
                    break
                key = _retarget(r.key, args.team)
                if r.encoding == ALIVE:      # the vehicle's liveliness, as it was
                    with lock:
                        if r.alive and key not in tokens:
                            tokens[key] = bus.session.liveliness().declare_token(key)
                        elif not r.alive and key in tokens:
                            tokens.pop(key).undeclare()
                    continue
                bus.put_raw(key, r.data, r.encoding)
                sent += 1
        finally:
            for t in tokens.values():
                t.undeclare()
    log.info("replayed %d messages in %.1f s", sent, time.monotonic() - t0)
    return 0
