"""Loopback latency and loss: the demo team (6 UGVs) for 60 s, on rendered frames (the UAV service
receives each 1280x720 frame over zenoh and runs the pixel pipeline) or on the sensor model.

Latency: a crowd message's arrival at each UGV service minus the capture time of the frame it came
from (same host clock): with rendered frames this includes moving the frame (2.8 MB raw) and the
UAV's detection, on a 2-core machine shared by all eleven processes. Loss: crowd messages the localizer published that a UGV service never got.
"""

from __future__ import annotations

import io
import re
import tempfile
from pathlib import Path

from uvteam.service import StopFlag

from .demo import DEFAULT_SCENARIO, Team, run_demo


def _num(note: str, name: str) -> float | None:
    m = re.search(rf"{name}=([-0-9.]+)", note)
    return float(m.group(1)) if m else None


def run(duration_s: float = 60.0, frames: str = "pixels") -> dict:
    d = Path(tempfile.mkdtemp(prefix="uvteam-bench-"))
    team = Team(str(DEFAULT_SCENARIO), duration_s=duration_s, workdir=str(d), log_level="WARNING", frames=frames)
    summary, codes = run_demo(team, StopFlag(install=False), live=False, out=io.StringIO())
    published = _num(summary["localizer_note"], "crowds_published") or 0
    p50 = [_num(n, "crowds_latency_p50_ms") for n in summary["ugv_notes"].values()]
    p99 = [_num(n, "crowds_latency_p99_ms") for n in summary["ugv_notes"].values()]
    got = [_num(n, "crowds_received") for n in summary["ugv_notes"].values()]
    loss = [1 - g / published for g in got if g is not None] if published else []
    print(f"latency ({frames}; frame capture -> crowds at a UGV service, loopback, {len(team.ugvs)} UGVs, {duration_s:.0f} s): "
          f"p50 {max(p for p in p50 if p is not None):.2f} ms (worst UGV), p99 {max(p for p in p99 if p is not None):.2f} ms "
          f"(worst UGV; target <= 50 ms)")
    print(f"crowd messages: localizer published {published:.0f}; per UGV received {[int(g) for g in got]}; "
          f"loss {max(loss) * 100:.2f} % (worst UGV; target 0)")
    print(f"accuracy in this run: mean {summary['mean_m']:.3f} m, p95 {summary['p95_m']:.3f} m over "
          f"{summary['frames_scored']} frames; exit codes {codes}")
    uav = summary["notes"].get(team.uav, "")
    if uav:
        print(f"UAV service: {uav}")
    return {"p50_ms": max(p50), "p99_ms": max(p99), "loss": max(loss), "published": published}
