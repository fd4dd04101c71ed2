"""Loopback latency, loss and memory: the demo team for 60 s, on rendered frames (the UAV service
receives each 1280x720 frame over zenoh and runs the pixel pipeline) or on the sensor model.

Latency: a crowd message's arrival at each UGV service minus the capture time of the frame it came
from (same host clock): with rendered frames this includes moving the frame (2.8 MB raw, through
zenoh's shared memory) and the UAV's detection, on a 2-core machine shared by every process of the
team. Loss: crowd messages the localizer published that a UGV service never got. Figures come from the
services' status metrics. Memory: each process's resident set (VmRSS, /proc/<pid>/status), the most
seen while the team ran; CPU: each process's user + system time over the run, in cores.

Two runs are the targets of issue 15: 6 UGVs on rendered frames (`--frames pixels`, p99 <= 40 ms) and
12 UGVs at 30 Hz on the sensor model (`--frames sensor --ugvs 12 --rate 30`, p99 <= 50 ms); the
scenario is the demo's with the UGV count and frame rate changed (written beside the logs).
"""

from __future__ import annotations

import io
import os
import re
import tempfile
import threading
import time
from pathlib import Path

from uvteam.service import StopFlag

from .bench_frames import cpu_s, machine_busy, rss_mb
from .demo import DEFAULT_SCENARIO, Team, run_demo

COLORS = ("red", "green", "blue", "yellow", "magenta", "cyan")
UGV_RSS_TARGET_MB = 150.0


def scenario_variant(out_dir: Path, ugvs: int | None = None, rate_hz: float | None = None) -> Path:
    """The demo scenario with ``ugvs`` UGVs (roof colors repeat past six: the sensor model does not
    need them apart) and frames at ``rate_hz``; the demo's own file when neither changes."""
    if ugvs is None and rate_hz is None:
        return DEFAULT_SCENARIO
    text = DEFAULT_SCENARIO.read_text()
    if ugvs is not None:
        colors = ", ".join(f'"{COLORS[i % len(COLORS)]}"' for i in range(ugvs))
        text = re.sub(r"(?m)^count = \d+", f"count = {ugvs}", text)
        text = re.sub(r"(?m)^colors = \[.*\]", f"colors = [{colors}]", text)
        text = re.sub(r'(?m)^name = "(.*)"', rf'name = "\1-{ugvs}ugv"', text)
    if rate_hz is not None:
        text = re.sub(r"(?m)^frame_rate_hz = [\d.]+", f"frame_rate_hz = {rate_hz}", text)
    path = out_dir / f"bench-{ugvs or 6}ugv-{rate_hz or 10:g}hz.toml"
    path.write_text(text)
    return path


class ProcessWatch:
    """Samples VmRSS of a team's processes while it runs; CPU seconds from their start to the last sample."""

    def __init__(self, procs: dict, period_s: float = 0.5) -> None:
        self.procs, self.period_s = procs, period_s
        self.rss: dict[str, float] = {}
        self.cpu: dict[str, float] = {}
        self._stop = threading.Event()
        self._t = threading.Thread(target=self._loop, daemon=True)

    def __enter__(self) -> "ProcessWatch":
        self._t.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._t.join(timeout=5)

    def _loop(self) -> None:
        while not self._stop.wait(self.period_s):
            for name, p in list(self.procs.items()):
                if p.poll() is None:
                    r = rss_mb(p.pid)
                    if r == r:
                        self.rss[name] = max(self.rss.get(name, 0.0), r)
                    self.cpu[name] = max(self.cpu.get(name, 0.0), cpu_s(p.pid))


def run(duration_s: float = 60.0, frames: str = "pixels", ugvs: int | None = None, rate_hz: float | None = None,
        quiet: bool = False) -> dict:
    d = Path(tempfile.mkdtemp(prefix="uvteam-bench-"))
    scenario = scenario_variant(d, ugvs, rate_hz)
    team = Team(str(scenario), duration_s=duration_s, workdir=str(d), log_level="WARNING", frames=frames)
    t0, (b0, j0) = time.monotonic(), machine_busy()
    with ProcessWatch(team.procs) as watch:
        summary, codes = run_demo(team, StopFlag(install=False), live=False, out=io.StringIO())
    wall_s = time.monotonic() - t0
    b1, j1 = machine_busy()
    busy = (b1 - b0) / (j1 - j0)    # of all cores, by every process on the machine
    m = summary["metrics"]
    published = m.get(team.localizer, {}).get("crowds_published", 0.0)
    ugv = [m.get(u, {}) for u in team.ugvs]
    p50 = [x["crowds_latency_p50_ms"] for x in ugv if "crowds_latency_p50_ms" in x]
    p99 = [x["crowds_latency_p99_ms"] for x in ugv if "crowds_latency_p99_ms" in x]
    got = [x.get("crowds_received", 0.0) for x in ugv]
    loss = [1 - g / published for g in got] if published else [1.0]
    rate = team.sc.run.frame_rate_hz
    target = 40.0 if frames == "pixels" else 50.0
    ugv_rss = [watch.rss.get(u, float("nan")) for u in team.ugvs]
    cores = sum(watch.cpu.values()) / wall_s
    res = {"p50_ms": max(p50, default=float("nan")), "p99_ms": max(p99, default=float("nan")), "loss": max(loss),
           "published": published, "rss_mb": dict(watch.rss), "cpu_s": dict(watch.cpu), "cores": cores,
           "ugvs": len(team.ugvs), "rate_hz": rate, "frames": frames, "machine_busy": busy}
    if quiet:
        return res
    print(f"latency ({frames}; frame capture -> crowds at a UGV service, loopback, {len(team.ugvs)} UGVs, "
          f"{rate:g} Hz, {duration_s:.0f} s): p50 {res['p50_ms']:.2f} ms (worst UGV), "
          f"p99 {res['p99_ms']:.2f} ms (worst UGV; target <= {target:.0f} ms)")
    print(f"crowd messages: localizer published {published:.0f}; per UGV received {[int(g) for g in got]}; "
          f"loss {max(loss) * 100:.2f} % (worst UGV; target 0)")
    print(f"accuracy in this run: mean {summary['mean_m']:.3f} m, p95 {summary['p95_m']:.3f} m over "
          f"{summary['n']} frames; exit codes {codes}")
    uav = m.get(team.uav, {})
    if uav:
        print("UAV service: " + " ".join(f"{k}={v:g}" for k, v in sorted(uav.items())))
    names = ["router", "sim", "localizer", team.uav, *team.ugvs]
    print("resident memory (VmRSS, most seen) and CPU (cores, over the run) per process:")
    print("  " + "  ".join(f"{n}={watch.rss.get(n, float('nan')):.0f}MB/{watch.cpu.get(n, 0.0) / wall_s:.2f}"
                           for n in names))
    print(f"  UGV services: most {max(ugv_rss):.0f} MB (target <= {UGV_RSS_TARGET_MB:.0f} MB); the team used "
          f"{cores:.2f} of the machine's {os.cpu_count()} cores on average (counting each process's start); the "
          f"machine was {busy * 100:.0f} % busy (every process on it, /proc/stat)")
    return res
