"""Loopback latency and loss: the demo team (6 UGVs) for 60 s, on rendered frames (the UAV service
receives each 1280x720 frame over zenoh and runs the pixel pipeline) or on the sensor model.

Latency: a crowd message's arrival at each UGV service minus the capture time of the frame it came
from (same host clock): with rendered frames this includes moving the frame (2.8 MB raw) and the
UAV's detection, on a 2-core machine shared by all eleven processes. Loss: crowd messages the
localizer published that a UGV service never got. Figures come from the services' status metrics.
"""

from __future__ import annotations

import io
import tempfile
from pathlib import Path

from uvteam.service import StopFlag

from .demo import DEFAULT_SCENARIO, Team, run_demo


def run(duration_s: float = 60.0, frames: str = "pixels") -> dict:
    d = Path(tempfile.mkdtemp(prefix="uvteam-bench-"))
    team = Team(str(DEFAULT_SCENARIO), duration_s=duration_s, workdir=str(d), log_level="WARNING", frames=frames)
    summary, codes = run_demo(team, StopFlag(install=False), live=False, out=io.StringIO())
    m = summary["metrics"]
    published = m.get(team.localizer, {}).get("crowds_published", 0.0)
    ugv = [m.get(u, {}) for u in team.ugvs]
    p50 = [x["crowds_latency_p50_ms"] for x in ugv if "crowds_latency_p50_ms" in x]
    p99 = [x["crowds_latency_p99_ms"] for x in ugv if "crowds_latency_p99_ms" in x]
    got = [x.get("crowds_received", 0.0) for x in ugv]
    loss = [1 - g / published for g in got] if published else [1.0]
    print(f"latency ({frames}; frame capture -> crowds at a UGV service, loopback, {len(team.ugvs)} UGVs, "
          f"{duration_s:.0f} s): p50 {max(p50, default=float('nan')):.2f} ms (worst UGV), "
          f"p99 {max(p99, default=float('nan')):.2f} ms (worst UGV; target <= 50 ms)")
    print(f"crowd messages: localizer published {published:.0f}; per UGV received {[int(g) for g in got]}; "
          f"loss {max(loss) * 100:.2f} % (worst UGV; target 0)")
    print(f"accuracy in this run: mean {summary['mean_m']:.3f} m, p95 {summary['p95_m']:.3f} m over "
          f"{summary['n']} frames; exit codes {codes}")
    uav = m.get(team.uav, {})
    if uav:
        print("UAV service: " + " ".join(f"{k}={v:g}" for k, v in sorted(uav.items())))
    return {"p50_ms": max(p50, default=float("nan")), "p99_ms": max(p99, default=float("nan")), "loss": max(loss),
            "published": published}
