"""Frames from the simulator to the UAV service over zenoh on one host (`uvteam bench frames`): shared
memory on and off, measured.

Three processes as in the demo: a router (``uvteam router``), a publisher playing the simulator (raw
1280x720 BGR frames, 2.8 MB each, encoded as the simulator encodes them) and a subscriber playing the UAV
service (decodes each :class:`uvteam.messages.Frame` and its pixels, as :class:`uvteam.nodes.uav.UavNode`
does). zenoh 1.10 moves a payload over 3 kB through a shared-memory pool between processes of one host
when both ends have ``transport/shared_memory`` enabled (the default: see ../shared/notes/zenoh.md); the
subscriber asks each sample whether it came that way (``ZBytes.as_shm()``). Figures: latency from the
frame's stamp (taken before encoding) to its pixels at the subscriber, and CPU time per frame of each
process (from /proc/<pid>/stat), with shared memory on, then off.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

from uvteam.bus import BusConfig
from uvteam.io.ports import free_port

from .demo import uvteam_command, wait_port

KEY = "uvteam/bench/uav1/frame"


def stop(p: subprocess.Popen | None, timeout_s: float = 5.0) -> None:
    """Terminates a process still running, and kills it if it has not gone within ``timeout_s``."""
    if p is None or p.poll() is not None:
        return
    p.terminate()
    try:
        p.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        p.kill()
        p.wait()


def cpu_s(pid: int) -> float:
    """User + system CPU seconds of a process (/proc/<pid>/stat), 0 when it is gone."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            parts = f.read().rsplit(")", 1)[1].split()
        return (int(parts[11]) + int(parts[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return 0.0


def machine_busy() -> tuple[float, float]:
    """(busy, total) jiffies of all cores since boot (/proc/stat): the machine's load, whoever made it."""
    with open("/proc/stat") as f:
        v = [int(x) for x in f.readline().split()[1:]]
    idle = v[3] + v[4]   # idle + iowait
    return float(sum(v) - idle), float(sum(v))


def rss_mb(pid: int) -> float:
    """Resident memory (VmRSS) of a process in MB, nan when it is gone."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except (OSError, ValueError):
        pass
    return float("nan")


def _subscriber(endpoint: str, shm: bool, n: int, out: str) -> int:
    """The UAV side: decode n frames, then write the figures to ``out`` (JSON)."""
    import threading  # noqa: PLC0415

    from uvteam.frames import frame_pixels  # noqa: PLC0415
    from uvteam.io.zenoh_bus import ZenohBus  # noqa: PLC0415
    from uvteam.messages import Frame, decode  # noqa: PLC0415

    lat, via_shm, done = [], [0], threading.Event()

    def on_sample(sample) -> None:
        if sample.payload.as_shm() is not None:
            via_shm[0] += 1
        fr = decode(Frame, sample.payload.to_bytes())
        frame_pixels(fr)
        lat.append((time.time() - fr.stamp_s) * 1e3)
        if len(lat) >= n:
            done.set()

    with ZenohBus.open(BusConfig(mode="client", connect=(endpoint,), shared_memory=shm)) as bus:
        sub = bus.session.declare_subscriber(KEY, on_sample)
        ready = bus.session.liveliness().declare_token("uvteam/bench/uav1/alive")
        t0 = time.process_time()
        done.wait(60.0)
        cpu = time.process_time() - t0
        ready.undeclare()
        sub.undeclare()
    with open(out, "w") as f:
        json.dump({"latency_ms": lat, "via_shm": via_shm[0], "cpu_s": cpu}, f)
    return 0


def run_mode(shm: bool, n: int = 100, rate_hz: float = 20.0, size: tuple[int, int] = (1280, 720)) -> dict:
    """One router, one subscriber process, this process publishing ``n`` frames at ``rate_hz``."""
    import tempfile  # noqa: PLC0415

    from uvteam.frames import encode_frame  # noqa: PLC0415
    from uvteam.io.zenoh_bus import ZenohBus  # noqa: PLC0415

    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    out = tempfile.mktemp(prefix="uvteam-bench-frames-", suffix=".json")
    router = subprocess.Popen([*uvteam_command(), "router", "--listen", endpoint], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL, start_new_session=True)
    sub = None
    try:
        if not wait_port(port, 15.0):
            raise RuntimeError("the router did not come up")
        sub = subprocess.Popen([sys.executable, "-m", "uvteam_ground.bench_frames", "--sub", endpoint,
                                "--shm", str(int(shm)), "-n", str(n), "--out", out], start_new_session=True)
        rng = np.random.default_rng(0)
        img = rng.integers(0, 255, (size[1], size[0], 3), np.uint8)
        with ZenohBus.open(BusConfig(mode="client", connect=(endpoint,), shared_memory=shm)) as bus:
            seen = []
            tok = bus.session.liveliness().declare_subscriber("uvteam/bench/uav1/alive", lambda s: seen.append(1))
            end = time.monotonic() + 20.0
            while not seen and time.monotonic() < end:
                time.sleep(0.05)
            time.sleep(0.3)
            pub = bus.session.declare_publisher(KEY, express=True, congestion_control=bus._zenoh.CongestionControl.BLOCK)
            from uvteam.messages import encode  # noqa: PLC0415

            r0, p0 = cpu_s(router.pid), time.process_time()
            t_next = time.monotonic()
            for k in range(n + 5):       # a few spare frames, in case the first ones beat the subscription
                stamp = time.time()
                pub.put(encode(encode_frame("uav1", stamp, k, img)))
                t_next += 1.0 / rate_hz
                time.sleep(max(0.0, t_next - time.monotonic()))
            pub_cpu = time.process_time() - p0
            router_cpu = cpu_s(router.pid) - r0
            sub_rss = rss_mb(sub.pid)
            sub.wait(timeout=60)
            tok.undeclare()
        with open(out) as f:
            got = json.load(f)
        os.unlink(out)
    finally:
        for p in (sub, router):
            stop(p)
    lat = np.array(got["latency_ms"])
    return {"shm": shm, "frames": len(lat), "via_shm": got["via_shm"],
            "p50_ms": float(np.percentile(lat, 50)) if len(lat) else float("nan"),
            "p99_ms": float(np.percentile(lat, 99)) if len(lat) else float("nan"),
            "pub_cpu_ms": pub_cpu / (n + 5) * 1e3, "router_cpu_ms": router_cpu / (n + 5) * 1e3,
            "sub_cpu_ms": got["cpu_s"] / max(1, len(lat)) * 1e3, "sub_rss_mb": sub_rss}


def run(n: int = 100) -> dict:
    import datetime  # noqa: PLC0415

    res = {m: run_mode(m, n) for m in (True, False)}
    print(f"frames sim -> UAV through a router, 1280x720 bgr8 (2.8 MB), {n} at 20 Hz ({datetime.date.today()}):")
    print(f"  {'shared memory':<14} {'via shm':>8} {'p50':>8} {'p99':>8} {'CPU/frame: pub':>15} {'router':>7} {'sub':>7}")
    for m, r in res.items():
        print(f"  {'on' if m else 'off':<14} {r['via_shm']:>4}/{r['frames']:<3} {r['p50_ms']:>5.1f} ms {r['p99_ms']:>5.1f} ms "
              f"{r['pub_cpu_ms']:>12.1f} ms {r['router_cpu_ms']:>4.1f} ms {r['sub_cpu_ms']:>4.1f} ms")
    on, off = res[True], res[False]
    print(f"  shared memory saves {off['p50_ms'] - on['p50_ms']:.1f} ms p50 latency and "
          f"{(off['pub_cpu_ms'] + off['router_cpu_ms'] + off['sub_cpu_ms']) - (on['pub_cpu_ms'] + on['router_cpu_ms'] + on['sub_cpu_ms']):.1f}"
          f" ms CPU per frame (all three processes)")
    return res


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="internal: the subscriber side of `uvteam bench frames`")
    ap.add_argument("--sub", required=True)
    ap.add_argument("--shm", type=int, default=1)
    ap.add_argument("-n", type=int, default=100)
    ap.add_argument("--out", required=True)
    a = ap.parse_args(argv)
    return _subscriber(a.sub, bool(a.shm), a.n, a.out)


if __name__ == "__main__":
    sys.exit(main())
