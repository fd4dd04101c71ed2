"""Teams through one router (`uvteam bench scaling`): N teams of 1 UAV + 6 UGVs on the sensor model,
each its own team name, all as clients of one `uvteam router` on loopback, N = 1, 2, ... until the knee.

For each N: the worst UGV's crowd latency (p50, p99: frame capture -> crowds at the UGV service), the
worst loss of crowd messages, every process's CPU (user + system, /proc/<pid>/stat) as cores over the
run, the router's share, and the UGV services' resident memory. The knee is the first N where the p99
more than doubles from N = 1 or crowd messages are lost; its cause is read off the CPU figures (the
machine has 2 cores: a team is 9 Python processes, plus the router).
"""

from __future__ import annotations

import datetime
import io
import os
import subprocess
import tempfile
import threading
import time
from pathlib import Path

from uvteam.io.ports import free_port
from uvteam.service import StopFlag

from .bench_frames import cpu_s, machine_busy, stop
from .bench_latency import ProcessWatch
from .demo import DEFAULT_SCENARIO, Team, wait_port, run_demo, uvteam_command


def run_teams(n: int, duration_s: float) -> dict:
    port = free_port()
    d = Path(tempfile.mkdtemp(prefix="uvteam-bench-scaling-"))
    log = open(d / "router.log", "wb")
    router = subprocess.Popen([*uvteam_command(), "router", "--listen", f"tcp/127.0.0.1:{port}"], stdout=log,
                              stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True)
    teams = [Team(str(DEFAULT_SCENARIO), team=f"t{i + 1}", duration_s=duration_s, workdir=str(d / f"t{i + 1}"),
                  log_level="WARNING", frames="sensor", router_port=port) for i in range(n)]
    results: list = [None] * n
    try:
        if not wait_port(port, 15.0):
            raise RuntimeError(f"the router did not come up; see {d / 'router.log'}")

        def one(i: int) -> None:
            results[i] = run_demo(teams[i], StopFlag(install=False), live=False, out=io.StringIO())

        procs: dict = {"router": router}
        watches = [ProcessWatch(t.procs) for t in teams] + [ProcessWatch(procs)]
        for w in watches:
            w.__enter__()
        t0, r0, (b0, j0) = time.monotonic(), cpu_s(router.pid), machine_busy()
        threads = [threading.Thread(target=one, args=(i,)) for i in range(n)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        wall = time.monotonic() - t0
        router_cores = (cpu_s(router.pid) - r0) / wall
        b1, j1 = machine_busy()
        for w in watches:
            w.__exit__()
    finally:
        stop(router)
        log.close()
    p50, p99, loss, rss = [], [], [], []
    for team, res in zip(teams, results):
        if res is None:
            loss.append(1.0)
            continue
        m = res[0]["metrics"]
        published = m.get(team.localizer, {}).get("crowds_published", 0.0)
        for u in team.ugvs:
            x = m.get(u, {})
            p50.append(x.get("crowds_latency_p50_ms", float("nan")))
            p99.append(x.get("crowds_latency_p99_ms", float("nan")))
            loss.append(1 - x.get("crowds_received", 0.0) / published if published else 1.0)
    cores = sum(sum(w.cpu.values()) for w in watches[:-1]) / wall + router_cores
    for w in watches[:-1]:
        rss += [v for k, v in w.rss.items() if k.startswith("ugv")]
    return {"teams": n, "processes": 9 * n + 1, "p50_ms": max(p50, default=float("nan")),
            "p99_ms": max(p99, default=float("nan")), "loss": max(loss, default=1.0), "cores": cores,
            "router_cores": router_cores, "ugv_rss_mb": max(rss, default=float("nan")), "wall_s": wall,
            "machine_busy": (b1 - b0) / (j1 - j0)}


def run(max_teams: int = 4, duration_s: float = 30.0) -> dict:
    print(f"scaling: N teams of 1 UAV + 6 UGVs (sensor model, 10 Hz) through one router, {duration_s:.0f} s each, "
          f"{os.cpu_count()} cores ({datetime.date.today()}):")
    print(f"  {'teams':>5} {'procs':>5} {'p50':>8} {'p99':>9} {'loss':>7} {'cores used':>10} {'router':>7} {'UGV RSS':>8} "
          f"{'machine busy':>12}")
    rows, knee = [], None
    for n in range(1, max_teams + 1):
        r = run_teams(n, duration_s)
        rows.append(r)
        print(f"  {n:>5} {r['processes']:>5} {r['p50_ms']:>5.1f} ms {r['p99_ms']:>6.1f} ms {r['loss'] * 100:>5.1f} % "
              f"{r['cores']:>10.2f} {r['router_cores']:>7.2f} {r['ugv_rss_mb']:>5.0f} MB {r['machine_busy'] * 100:>10.0f} %",
              flush=True)
        if knee is None and (r["loss"] > 0.0 or r["p99_ms"] > 2 * rows[0]["p99_ms"]):
            knee = n
            break
    if knee is None:
        print(f"  no knee up to {max_teams} teams")
    else:
        print(f"  knee at {knee} teams: p99 {rows[0]['p99_ms']:.1f} -> {rows[-1]['p99_ms']:.1f} ms, loss "
              f"{rows[-1]['loss'] * 100:.1f} %, the teams used {rows[-1]['cores']:.2f} of {os.cpu_count()} cores and the "
              f"machine was {rows[-1]['machine_busy'] * 100:.0f} % busy")
    return {"rows": rows, "knee": knee}
