"""`uvteam tap`: watch the bus from a laptop.

    uvteam tap --connect tcp/10.0.0.1:7447                     every uvteam key, as JSON lines
    uvteam tap 'uvteam/demo/*/crowds' --connect ...           one topic of every vehicle
    uvteam tap --summary --team demo --connect ...            live table: vehicles, fix age, rates, rejected, crowds

Camera frames (``.../frame``, megabytes each) are not pulled unless asked for with ``--frames`` or
named in the key expression. Payloads that do not decode are reported on stderr with their key,
counted, and skipped.
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from collections import defaultdict, deque

from uvteam import keys, messages
from uvteam.bus import BusConfig
from uvteam.io.zenoh_bus import ZenohBus, add_bus_args, bus_config_from_args
from uvteam.errors import ConfigError, LinkError, MessageError
from uvteam.service import StopFlag
from uvteam.vocab import is_id


def _typed(key: str):
    return messages.BY_TOPIC.get(keys.topic_of(key) or "")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uvteam tap", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("keyexpr", nargs="?", default=None, help="key expression (default: uvteam/** or the team's)")
    ap.add_argument("--team", default=None)
    ap.add_argument("--summary", action="store_true", help="a live table instead of JSON lines")
    ap.add_argument("--count", type=int, default=0, help="exit after this many messages (0 = run until Ctrl-C)")
    ap.add_argument("--duration", type=float, default=0.0, help="exit after this many seconds")
    ap.add_argument("--frames", action="store_true", help="also pull camera frames (.../frame; large)")
    add_bus_args(ap)
    args = ap.parse_args(argv)
    if args.team is not None and not is_id(args.team):
        print(f"uvteam tap: --team must be an id (1-32 of A-Z a-z 0-9 _ -), got {args.team!r}", file=sys.stderr)
        return 2
    stop = StopFlag()
    lock = threading.Lock()
    stats = {"n": 0, "bad": 0}
    seen = defaultdict(lambda: {"n": 0, "last": 0.0, "first": time.time(), "times": deque(maxlen=100)})
    alive: dict[str, bool] = {}
    last_msg: dict[str, object] = {}
    try:
        cfg = bus_config_from_args(args, BusConfig(mode="client") if args.connect else None)
        bus = ZenohBus.open(cfg)
    except ConfigError as exc:
        print(f"uvteam tap: configuration error: {exc}", file=sys.stderr)
        return 2
    except LinkError as exc:
        print(f"uvteam tap: {exc}", file=sys.stderr)
        return 3
    with bus:
        def on_sample(sample) -> None:
            k = str(sample.key_expr)
            cls = _typed(k)
            raw = sample.payload.to_bytes()
            try:
                msg = messages.decode(cls, raw) if cls else None
            except MessageError as exc:
                with lock:
                    stats["bad"] += 1
                print(f"rejected {k}: {exc}", file=sys.stderr)
                return
            with lock:
                stats["n"] += 1
                s = seen[k]
                s["n"] += 1
                s["last"] = time.time()
                s["times"].append(s["last"])
                last_msg[k] = msg
                n = stats["n"]
            if not args.summary:
                out = messages.as_dict(msg) if msg is not None else {"raw_bytes": len(raw)}
                out = {k2: (f"<{len(v)} bytes>" if isinstance(v, bytes) else v) for k2, v in out.items()}
                print(json.dumps({"key": k, **out}, separators=(",", ":")), flush=True)
            if args.count and n >= args.count:
                stop.set()

        if args.keyexpr:
            exprs = [args.keyexpr]
        else:   # every topic but frames (megabytes each), unless asked for: never pulled over the link
            team = args.team or "*"
            exprs = [f"{keys.ROOT}/{team}/*/{t}" for t in keys.TOPICS if t != "frame" or args.frames]
        subs = [bus.session.declare_subscriber(e, on_sample) for e in exprs]
        bus._subs.extend(subs)
        bus.watch_alive(keys.alive_all(args.team) if args.team else "uvteam/*/*/alive",
                        lambda k, up: alive.__setitem__(keys.vehicle_of(k) or k, up))
        t_end = time.time() + args.duration if args.duration else float("inf")
        while not stop.wait(1.0 if args.summary else 0.1):
            if time.time() >= t_end:
                break
            if args.summary:
                _draw(seen, alive, last_msg, stats, lock)
    return 0


def _draw(seen, alive, last_msg, stats, lock) -> None:
    now = time.time()
    rows = []
    with lock:
        vehicles = sorted({keys.vehicle_of(k) for k in seen if keys.vehicle_of(k)} | set(alive))
        for v in vehicles:
            fix = last_msg.get(next((k for k in seen if keys.vehicle_of(k) == v and k.endswith("/fix")), ""), None)
            st = last_msg.get(next((k for k in seen if keys.vehicle_of(k) == v and k.endswith("/status")), ""), None)
            # messages per second over the last 5 s, or since the key was first seen if that is sooner
            rate = sum(len([t for t in s["times"] if now - t < 5]) / max(min(5.0, now - s["first"]), 1.0)
                       for k, s in seen.items() if keys.vehicle_of(k) == v)
            metrics = " ".join(f"{k}={x:g}" for k, x in sorted(st.metrics.items())) if st else ""
            rows.append(f"{v:<10} {'yes' if alive.get(v) else 'NO ':<5} "
                        f"{(f'{now - fix.stamp_s:5.2f}' if fix else '  -  '):>7} {rate:7.1f} "
                        f"{(st.link if st else '-'):>5} {(st.rejected if st else 0):>8}  {st.note if st else ''}"
                        + (f"\n{'':<10} {metrics}" if metrics else ""))
        crowds = [m for k, m in last_msg.items() if k.endswith("/crowds")]
        bad = stats["bad"]
    out = ["\x1b[2J\x1b[H" if sys.stdout.isatty() else "", f"uvteam tap --summary  {time.strftime('%H:%M:%S')}  "
           f"undecodable here: {bad}", f"{'vehicle':<10} {'alive':<5} {'fix age':>7} {'msg/s':>7} {'link':>5} "
           f"{'rejected':>8}  note"] + rows
    for m in crowds:
        for c in m.crowds:
            out.append(f"crowd {c.crowd_id}: {c.lat_deg:.6f}, {c.lon_deg:.6f}  r95 {c.radius95_m:.2f} m  {c.quality}  "
                       f"v ({c.v_east_m_s:+.1f}, {c.v_north_m_s:+.1f}) m/s"
                       + (f"  unseen {c.unseen_s:.1f} s" if c.unseen_s > 0 else ""))
    print("\n".join(out), flush=True)
