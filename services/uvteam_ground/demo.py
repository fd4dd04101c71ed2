"""`uvteam demo`: the whole team on loopback, as separate processes, with a live view.

Starts a zenoh router, the localizer, the UAV service, one service per UGV (each with its own MAVLink
UDP port) and the simulator, which plays every autopilot and the UAV camera. Shows, once a second,
the crowd estimate beside the truth with the error in metres and which vehicles are alive; stops all
processes on Ctrl-C or at the scenario's end and prints the error summary. Scenario events are played
for real: a UGV lost at t seconds has its service killed (SIGKILL) at t.

    uvteam demo                                             the default scenario (deploy/scenarios/demo.toml)
    uvteam demo --scenario ../shared/scenarios/paper-fig8-lm6.toml --duration 20
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from uvteam import keys
from uvteam.bus import BusConfig
from uvteam.io.zenoh_bus import ZenohBus
from uvteam.geo import LocalFrame
from uvteam.messages import Crowds, Status, Truth
from uvteam.service import StopFlag

REPO = Path(__file__).resolve().parents[2]
DEFAULT_SCENARIO = REPO / "deploy" / "scenarios" / "demo.toml"


def free_port(kind: int = socket.SOCK_STREAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_port(port: int, timeout_s: float) -> bool:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return True
        time.sleep(0.05)
    return False


class Team:
    """Configs and processes of one loopback team."""

    def __init__(self, scenario_path: str, *, team: str = "demo", seed: int | None = None,
                 duration_s: float | None = None, workdir: str | None = None, log_level: str = "INFO",
                 frames: str = "pixels") -> None:
        from uvteam.io.files import load_scenario  # noqa: PLC0415

        self.sc = load_scenario(scenario_path)
        self.scenario_path = str(scenario_path)
        self.team, self.seed, self.duration_s = team, seed, duration_s or self.sc.run.duration_s
        self.dir = Path(workdir or tempfile.mkdtemp(prefix="uvteam-demo-"))
        (self.dir / "logs").mkdir(parents=True, exist_ok=True)
        self.router_port = free_port()
        self.endpoint = f"tcp/127.0.0.1:{self.router_port}"
        self.ugvs = [f"ugv{i + 1}" for i in range(self.sc.ugvs.count)]
        self.uav = "uav1"
        self.ports = {v: free_port(socket.SOCK_DGRAM) for v in [self.uav] + self.ugvs}
        self.sysid = {self.uav: 1, **{u: 11 + i for i, u in enumerate(self.ugvs)}}
        self.procs: dict[str, subprocess.Popen] = {}
        self.log_level = log_level
        if frames not in ("pixels", "sensor"):
            raise ValueError(f"frames must be 'pixels' or 'sensor', got {frames!r}")
        self.frames = frames
        self.expected_exit: set[str] = set()
        self._write_configs()

    def _bus(self) -> str:
        return f'[bus]\nmode = "client"\nconnect = ["{self.endpoint}"]\n'

    def _write_configs(self) -> None:
        from uvteam.camera import PinholeCamera  # noqa: PLC0415

        sc = self.sc
        fw, fh = PinholeCamera(sc.camera.width_px, sc.camera.height_px, sc.camera.hfov_deg).footprint_m(sc.uav.altitude_agl_m)
        colors = ", ".join(f'{c} = "{u}"' for c, u in zip(sc.ugvs.colors, self.ugvs))
        (self.dir / "uav1.toml").write_text(
            f'[vehicle]\nteam = "{self.team}"\nid = "{self.uav}"\nrole = "uav"\n\n{self._bus()}\n'
            f'[autopilot]\nurl = "udpin:127.0.0.1:{self.ports[self.uav]}"\nsystem_id = {self.sysid[self.uav]}\n\n'
            f'[uav]\ndetector = "{"pixels" if self.frames == "pixels" else "sim-sensor"}"\ncamera = "zenoh"\n'
            f'hfov_deg = {sc.camera.hfov_deg}\nlabel_side_m = {sc.ugvs.label_side_m}\ncolors = {{ {colors} }}\n')
        ugv_list = ", ".join(f'"{u}"' for u in self.ugvs)
        for u in self.ugvs:
            (self.dir / f"{u}.toml").write_text(
                f'[vehicle]\nteam = "{self.team}"\nid = "{u}"\nrole = "ugv"\n\n{self._bus()}\n'
                f'[autopilot]\nurl = "udpin:127.0.0.1:{self.ports[u]}"\nsystem_id = {self.sysid[u]}\n\n'
                f'[ugv]\nuav = "{self.uav}"\nteam_ugvs = [{ugv_list}]\nstation_radius_m = {sc.ugvs.station_radius_m}\n'
                f'max_speed_m_s = {sc.ugvs.approach_speed_m_s}\nview_half_width_m = {fw / 2:.2f}\n'
                f'view_half_height_m = {fh / 2:.2f}\n')
        from uvteam.detector_noise import localizer_sigmas_px  # noqa: PLC0415

        s_lm, s_tg = localizer_sigmas_px(self.frames, sc.landmarks.image_coordinates, sc.uav.altitude_agl_m,
                                         PinholeCamera(sc.camera.width_px, sc.camera.height_px, sc.camera.hfov_deg).focal_px)
        (self.dir / "localizer.toml").write_text(
            f'[vehicle]\nteam = "{self.team}"\nid = "loc1"\nrole = "localizer"\n\n{self._bus()}\n'
            f'[localizer]\nuav = "{self.uav}"\nugvs = [{ugv_list}]\norigin_lat_deg = {sc.world.origin_lat_deg}\n'
            f'origin_lon_deg = {sc.world.origin_lon_deg}\nimage_coordinates = "{sc.landmarks.image_coordinates}"\n'
            f'sigma_landmark_px = {s_lm:.3f}\nsigma_target_px = {s_tg:.3f}\n')

    def _spawn(self, name: str, args: list[str]) -> None:
        log = open(self.dir / "logs" / f"{name}.log", "wb")
        self.procs[name] = subprocess.Popen([sys.executable, "-m", "uvteam", *args], stdout=log, stderr=subprocess.STDOUT,
                                            stdin=subprocess.DEVNULL, start_new_session=True)

    def start(self) -> None:
        self._spawn("router", ["router", "--listen", self.endpoint])
        if not _wait_port(self.router_port, 15.0):
            raise RuntimeError(f"the router did not come up; see {self.dir / 'logs' / 'router.log'}")
        ll = ["--log-level", self.log_level]
        self._spawn("localizer", ["localizer", "--config", str(self.dir / "localizer.toml"), *ll])
        self._spawn(self.uav, ["uav", "--config", str(self.dir / "uav1.toml"), *ll])
        for u in self.ugvs:
            self._spawn(u, ["ugv", "--config", str(self.dir / f"{u}.toml"), *ll])

    def start_sim(self) -> None:
        args = ["sim", "--scenario", self.scenario_path, "--team", self.team, "--mode", "client",
                "--connect", self.endpoint, "--duration", str(self.duration_s),
                "--uav", f"{self.uav}:{self.ports[self.uav]}:{self.sysid[self.uav]}", "--log-level", self.log_level,
                "--frames", self.frames]
        if self.seed is not None:
            args += ["--seed", str(self.seed)]
        for u in self.ugvs:
            args += ["--ugv", f"{u}:{self.ports[u]}:{self.sysid[u]}"]
        self._spawn("sim", args)

    def kill(self, name: str, sig: int = signal.SIGKILL) -> None:
        p = self.procs.get(name)
        if p is not None and p.poll() is None:
            self.expected_exit.add(name)
            os.killpg(p.pid, sig)

    def crashed(self) -> list[str]:
        return [n for n, p in self.procs.items() if p.poll() not in (None, 0) and n not in self.expected_exit]

    def stop(self, timeout_s: float = 8.0) -> dict[str, int | None]:
        order = ["sim"] + self.ugvs + [self.uav, "localizer", "router"]
        for n in order:
            p = self.procs.get(n)
            if p is not None and p.poll() is None:
                try:
                    os.killpg(p.pid, signal.SIGTERM)
                except ProcessLookupError:
                    pass
        end = time.monotonic() + timeout_s
        for n in order:
            p = self.procs.get(n)
            if p is None:
                continue
            try:
                p.wait(timeout=max(end - time.monotonic(), 0.1))
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait(timeout=5)
        return {n: p.returncode for n, p in self.procs.items()}

    def observer_bus(self) -> BusConfig:
        """How the demo's own view joins the team's bus."""
        return BusConfig(mode="client", connect=(self.endpoint,))

    def tail(self, name: str, n: int = 15) -> str:
        try:
            return "\n".join((self.dir / "logs" / f"{name}.log").read_text(errors="replace").splitlines()[-n:])
        except OSError:
            return ""


class Observer:
    """A laptop-side view of the team: crowds vs truth, statuses, liveliness."""

    def __init__(self, team: Team) -> None:
        self.team = team
        self.frame = LocalFrame(team.sc.world.origin_lat_deg, team.sc.world.origin_lon_deg)
        self.lock = threading.Lock()
        self.truth: dict[int, Truth] = {}
        self.crowds: dict[int, Crowds] = {}
        self.status: dict[str, Status] = {}
        self.alive: dict[str, bool] = {}
        self.errors: list[tuple[float, float, float]] = []   # (stamp, error m, radius95)
        self.false_crowds = 0
        self.truth_frames = 0
        self.matched = 0
        self.crowds_msgs = 0
        self.last_line = ""

    @staticmethod
    def _ms(stamp: float) -> int:
        return int(round(stamp * 1000))

    def on_truth(self, key: str, t: Truth) -> None:
        with self.lock:
            self.truth[self._ms(t.stamp_s)] = t
            self._score(self._ms(t.stamp_s))

    def on_crowds(self, key: str, c: Crowds) -> None:
        with self.lock:
            self.crowds_msgs += 1
            self.crowds[self._ms(c.stamp_s)] = c
            self._score(self._ms(c.stamp_s))

    def _score(self, ms: int) -> None:
        t, c = self.truth.get(ms), self.crowds.get(ms)
        if t is None or c is None:
            return
        del self.crowds[ms]
        tru = np.array([self.frame.wgs84_to_ground(x.lat_deg, x.lon_deg) for x in t.crowds], float).reshape(-1, 2)
        rep = np.array([self.frame.wgs84_to_ground(x.lat_deg, x.lon_deg) for x in c.crowds], float).reshape(-1, 2)
        used_t = set()
        for i, r in enumerate(rep):
            d = np.sqrt(((tru - r) ** 2).sum(1)) if len(tru) else np.empty(0)
            j = int(d.argmin()) if len(d) else -1
            if j >= 0 and d[j] <= 10.0 and j not in used_t:
                used_t.add(j)
                self.errors.append((t.stamp_s, float(d[j]), c.crowds[i].radius95_m))
            else:
                self.false_crowds += 1
        self.matched += len(used_t)
        err = [e for s, e, _ in self.errors[-len(used_t):]] if used_t else []
        self.last_line = (f"frame {t.frame_seq:5d}  crowds {len(rep)}/{len(tru)}  quality {c.quality:<13} "
                          f"error {'/'.join(f'{e:.2f}' for e in err) or '-':>6} m  landmarks {len(c.landmarks_used)}")

    def on_status(self, key: str, s: Status) -> None:
        with self.lock:
            self.status[s.vehicle] = s

    def on_alive(self, key: str, up: bool) -> None:
        with self.lock:
            self.alive[keys.vehicle_of(key) or key] = up

    def count_truth_frames(self, after_s: float) -> None:
        with self.lock:
            self.truth_frames = sum(len(t.crowds) for t in self.truth.values() if t.stamp_s >= after_s)

    def summary(self, start_s: float) -> dict:
        self.count_truth_frames(start_s + 1.0)
        with self.lock:
            e = np.array([x[1] for x in self.errors])
            r = np.array([x[2] for x in self.errors])
            matched_after = sum(1 for s, _, _ in self.errors if s >= start_s + 1.0)
            lat = {v: s.note for v, s in self.status.items() if s.service == "ugv"}
            loc = next((s.note for s in self.status.values() if s.service == "localizer"), "")
            rejected = {v: s.rejected for v, s in self.status.items()}
        return {
            "frames_scored": int(len(e)),
            "mean_m": float(e.mean()) if len(e) else math.nan,
            "median_m": float(np.median(e)) if len(e) else math.nan,
            "p95_m": float(np.percentile(e, 95)) if len(e) else math.nan,
            "max_m": float(e.max()) if len(e) else math.nan,
            "in_radius95": float(np.mean(e <= r)) if len(e) else math.nan,
            "recall_after_1s": matched_after / self.truth_frames if self.truth_frames else math.nan,
            "false_crowds": self.false_crowds,
            "ugv_notes": lat,
            "notes": {v: s.note for v, s in self.status.items()},
            "localizer_note": loc,
            "rejected": rejected,
        }


def _view(obs: Observer, team: Team, t_rel: float) -> str:
    with obs.lock:
        alive = " ".join(f"{v}{'+' if up else '-'}" for v, up in sorted(obs.alive.items()) if v not in ("sim",))
        line = obs.last_line
        e = [x[1] for x in obs.errors]
    mean = f"{np.mean(e):.2f}" if e else "-"
    return f"t={t_rel:5.1f}s  {line or 'waiting for the first crowd...'}  | mean {mean} m | alive: {alive}"


def run_demo(team: Team, stop: StopFlag, *, live: bool = True, out=sys.stdout) -> tuple[dict, dict]:
    obs = Observer(team)
    team.start()
    bus = ZenohBus.open(team.observer_bus())
    try:
        bus.subscribe(keys.key(team.team, "sim", "truth"), Truth, obs.on_truth)
        bus.subscribe(keys.key(team.team, team.uav, "crowds"), Crowds, obs.on_crowds)
        bus.subscribe(keys.all_vehicles(team.team, "status"), Status, obs.on_status)
        bus.watch_alive(keys.alive_all(team.team), obs.on_alive)
        # let the services open their sessions before the simulator starts the clock
        end_wait = time.monotonic() + 20.0
        want = {"loc1", team.uav, *team.ugvs}
        while time.monotonic() < end_wait and not stop.is_set():
            with obs.lock:
                if want <= {v for v, up in obs.alive.items() if up}:
                    break
            if team.crashed():
                break
            time.sleep(0.1)
        t0 = time.time()
        team.start_sim()
        lost = {team.ugvs[int(i)]: float(t) for i, t in team.sc.events.lose_ugv}
        next_view = 0.0
        while not stop.wait(0.1):
            t_rel = time.time() - t0
            for u, at in lost.items():
                if t_rel >= at and u not in team.expected_exit:
                    team.kill(u)
                    print(f"t={t_rel:5.1f}s  scenario event: {u}'s service killed (SIGKILL)", file=out, flush=True)
            if live and t_rel >= next_view:
                print(_view(obs, team, t_rel), file=out, flush=True)
                next_view = t_rel + 1.0
            if team.procs["sim"].poll() is not None:
                break
            bad = team.crashed()
            if bad:
                print(f"uvteam demo: {', '.join(bad)} exited unexpectedly:\n" +
                      "\n".join(team.tail(b) for b in bad), file=out, flush=True)
                break
        time.sleep(1.5)  # the last crowds messages and one more status from every service
    finally:
        codes = team.stop()
        bus.close()
    return obs.summary(t0), codes


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uvteam demo", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenario", default=str(DEFAULT_SCENARIO), help="scenario TOML (default: %(default)s)")
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--duration", type=float, default=None, help="seconds (default: the scenario's)")
    ap.add_argument("--quiet", action="store_true", help="no live view, only the summary")
    ap.add_argument("--frames", choices=["pixels", "sensor"], default="pixels",
                    help="pixels: the simulator renders camera frames and the UAV service detects on them "
                         "(default); sensor: the simulator's sensor model replaces the UAV's vision")
    ap.add_argument("--json", metavar="FILE", help="also write the summary as JSON")
    ap.add_argument("--workdir", help="where configs and logs go (default: a new temporary folder)")
    args = ap.parse_args(argv)
    stop = StopFlag()
    team = Team(args.scenario, seed=args.seed, duration_s=args.duration, workdir=args.workdir, frames=args.frames)
    print(f"uvteam demo: {team.sc.name}, {len(team.ugvs)} UGVs, {team.duration_s:.0f} s; router {team.endpoint}; "
          f"configs and logs in {team.dir}", flush=True)
    print(f"  watch from another terminal: uvteam tap --summary --team {team.team} --connect {team.endpoint}", flush=True)
    summary, codes = run_demo(team, stop, live=not args.quiet)
    print("\nsummary (crowd estimate vs truth, per frame):")
    print(f"  frames scored {summary['frames_scored']}, mean {summary['mean_m']:.3f} m, median {summary['median_m']:.3f} m, "
          f"p95 {summary['p95_m']:.3f} m, max {summary['max_m']:.3f} m")
    print(f"  recall after 1 s {summary['recall_after_1s']:.3f}, false crowds {summary['false_crowds']}, "
          f"inside the reported 95% radius {summary['in_radius95']:.3f}")
    uav_note = summary["notes"].get(team.uav, "")
    if uav_note:
        print(f"  {team.uav}: {uav_note}")
    for v, note in sorted(summary["ugv_notes"].items()):
        print(f"  {v}: {note}")
    print(f"  rejected messages: {summary['rejected']}")
    print(f"  exit codes: {codes}")
    if args.json:
        Path(args.json).write_text(json.dumps({"summary": summary, "exit_codes": codes}, indent=2))
    bad = [n for n, c in codes.items() if c not in (0, None, -signal.SIGTERM) and n not in team.expected_exit]
    return 1 if bad or summary["frames_scored"] == 0 else 0
