"""`uvteam demo`: the whole team on loopback, as separate processes, with a live view.

Starts a zenoh router, the localizer, the UAV service, one service per UGV (each with its own MAVLink
UDP port) and the simulator, which plays every autopilot and the UAV camera. The services run on the
configs an operator would write (:func:`uvteam.team.team_configs`, written as TOML files beside the
logs): the shipped defaults plus the team's ids and colors. Shows, once a second, the first crowd's
position, its error against the truth and its 95 % radius; stops all processes on Ctrl-C or at the
scenario's end and prints the scores (:mod:`uvteam.scoring`, as the experiment's). Scenario events are
played for real: a UGV lost at t seconds has its service killed (SIGKILL) at t.

    uvteam demo                                       the default scenario (6 UGVs, 50 m, 30 s)
    uvteam demo --scenario ../shared/scenarios/paper-fig8-lm6.toml --duration 20
    uvteam demo --secure                              the same under the secure profile (uvteam certs:
                                                      TLS, client certificates, access control)
    uvteam demo -l tcp/0.0.0.0:7447                   its router also listens there: watch from another host

The zenoh flags (-l/--listen, -e/--connect, --cfg, --zenoh-config) go to the router the demo starts;
the team's own processes stay on loopback.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import replace
from pathlib import Path

from uvteam import keys
from uvteam.bus import BusConfig
from uvteam.config import vehicle_config_to_toml
from uvteam.errors import ConfigError
from uvteam.geo import LocalFrame
from uvteam.io.files import load_scenario
from uvteam.io.ports import free_port
from uvteam.io.recording import McapRecorder, attach_zenoh
from uvteam.io.zenoh_bus import ZenohBus, add_bus_args, parse_cfg
from uvteam.messages import Crowds, Status, Truth
from uvteam.scoring import BusScorer, summarize
from uvteam.service import StopFlag
from uvteam.team import TeamLayout, team_configs

DEFAULT_SCENARIO = Path(__file__).resolve().parent / "data" / "demo.toml"
FRAMES = {"pixels": "pixels", "sensor": "sim-sensor"}


def wait_port(port: int, timeout_s: float = 15.0) -> bool:
    """Whether something accepts TCP connections on 127.0.0.1:``port`` within ``timeout_s``."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return True
        time.sleep(0.05)
    return False


def uvteam_command() -> list[str]:
    """How to run `uvteam` here: the console script beside this Python if there is one, else -m."""
    script = Path(sys.executable).with_name("uvteam")
    return [str(script)] if script.exists() else [sys.executable, "-m", "uvteam"]


class Team:
    """Configs and processes of one loopback team."""

    def __init__(self, scenario_path: str, *, team: str = "demo", seed: int | None = None,
                 duration_s: float | None = None, workdir: str | None = None, log_level: str = "INFO",
                 frames: str = "pixels", secure: bool = False, map_http: str | None = None,
                 annotate: bool = False, router_args: tuple[str, ...] = (), router_port: int | None = None) -> None:
        if frames not in FRAMES:
            raise ValueError(f"frames must be 'pixels' or 'sensor', got {frames!r}")
        self.sc = load_scenario(scenario_path)
        self.scenario_path = str(scenario_path)
        self.seed, self.duration_s = seed, duration_s or self.sc.run.duration_s
        self.dir = Path(workdir or tempfile.mkdtemp(prefix="uvteam-demo-"))
        (self.dir / "logs").mkdir(parents=True, exist_ok=True)
        self.own_router = router_port is None   # else: join a router already listening on 127.0.0.1:router_port
        # ports named for processes not started yet (the map's chosen before the team)
        self.named_ports: set[int] = {p for p in (router_port, map_http and int(map_http.rpartition(":")[2])) if p}
        self.router_port = self.free_port() if router_port is None else router_port
        self.secure = secure
        self.endpoint = f"{'tls' if secure else 'tcp'}/127.0.0.1:{self.router_port}"
        base = TeamLayout.for_scenario(self.sc, team)
        self.ports = {v: self.free_port(socket.SOCK_DGRAM) for v in (base.uav, *base.ugvs)}
        self.layout = TeamLayout(team, base.uav, base.localizer, base.ugvs,
                                 {v: f"udpin:127.0.0.1:{p}" for v, p in self.ports.items()}, base.system_ids)
        self.team, self.uav, self.localizer, self.ugvs = team, base.uav, base.localizer, list(base.ugvs)
        self.procs: dict[str, subprocess.Popen] = {}
        self.args: dict[str, list[str]] = {}
        self.logs: dict[str, object] = {}
        self.log_level = log_level
        self.frames = frames
        self.expected_exit: set[str] = set()
        self.configs = team_configs(self.sc, self.layout, detector=FRAMES[frames],
                                    bus=BusConfig(mode="client", connect=(self.endpoint,)))
        if secure:   # every member on its own certificate and generated zenoh config; the view reads only
            from .certs import Roster, write_team  # noqa: PLC0415

            write_team(Roster(team, (self.uav,), tuple(self.ugvs), ((self.localizer, self.uav),), ("sim",), ("view",)),
                       self.secrets, router_hosts=("127.0.0.1",), listen=(self.endpoint,))
            self.configs = {v: replace(c, bus=self.member_bus(v)) for v, c in self.configs.items()}
        self.annotate_url = None
        if annotate and frames == "pixels":   # what the UAV sees, drawn, as MJPEG on a loopback port
            port = self.free_port()
            u = self.configs[self.uav]
            self.configs[self.uav] = replace(u, uav=replace(u.uav, annotate_http=f"127.0.0.1:{port}"))
            self.annotate_url = f"http://127.0.0.1:{port}/stream.mjpg"
        self.map_http = map_http
        self.router_args = tuple(router_args)     # zenoh flags the user gave the demo, for its router
        for vid, cfg in self.configs.items():
            (self.dir / f"{vid}.toml").write_text(vehicle_config_to_toml(cfg, f"uvteam demo: {vid} ({cfg.role})"))

    def free_port(self, kind: int = socket.SOCK_STREAM) -> int:
        """A loopback port for one of the team's processes, none the team named already (they bind later)."""
        port = free_port(kind, taken=self.named_ports)
        self.named_ports.add(port)
        return port

    @property
    def secrets(self) -> Path:
        return self.dir / "secrets"

    def member_bus(self, member: str) -> BusConfig:
        """How a member (or the demo's view, "view") joins the team's bus."""
        if self.secure:
            return BusConfig(config_file=str(self.secrets / f"{member}.json5"))
        return BusConfig(mode="client", connect=(self.endpoint,))

    def _spawn(self, name: str, args: list[str]) -> None:
        old = self.logs.get(name)
        if old is not None:
            old.close()
        log = self.logs[name] = open(self.dir / "logs" / f"{name}.log", "ab")
        self.args[name] = args
        self.procs[name] = subprocess.Popen([*uvteam_command(), *args], stdout=log, stderr=subprocess.STDOUT,
                                            stdin=subprocess.DEVNULL, start_new_session=True)

    def restart(self, name: str) -> None:
        """Start a process again as it was started (after a kill: a vehicle's computer rebooting)."""
        self._spawn(name, self.args[name])      # the new process first: the killed one is never seen as crashed
        self.expected_exit.discard(name)

    def start(self) -> None:
        if self.own_router:
            self._spawn("router", ["router", "--zenoh-config", str(self.secrets / "router.json5")] if self.secure
                        else ["router", "--listen", self.endpoint, *self.router_args])
        if not wait_port(self.router_port, 15.0):
            raise RuntimeError(f"the router did not come up; see {self.dir / 'logs' / 'router.log'}")
        ll = ["--log-level", self.log_level]
        self._spawn("localizer", ["localizer", "--config", str(self.dir / f"{self.localizer}.toml"), *ll])
        self._spawn(self.uav, ["uav", "--config", str(self.dir / f"{self.uav}.toml"), *ll])
        for u in self.ugvs:
            self._spawn(u, ["ugv", "--config", str(self.dir / f"{u}.toml"), *ll])
        if self.map_http:
            join = ["--zenoh-config", str(self.secrets / "view.json5")] if self.secure else ["--connect", self.endpoint]
            self._spawn("map", ["map", "--team", self.team, "--http", self.map_http, *join, *ll,
                                *(["--video", self.annotate_url] if self.annotate_url else [])])

    @property
    def map_url(self) -> str | None:
        return f"http://{self.map_http}/" if self.map_http else None

    def start_sim(self) -> None:
        sysid = self.layout.system_ids
        args = ["sim", "--scenario", self.scenario_path, "--team", self.team, "--mode", "client",
                "--connect", self.endpoint, "--duration", str(self.duration_s),
                "--uav", f"{self.uav}:{self.ports[self.uav]}:{sysid[self.uav]}", "--log-level", self.log_level,
                "--frames", self.frames]
        if self.seed is not None:
            args += ["--seed", str(self.seed)]
        if self.secure:
            args += ["--zenoh-config", str(self.secrets / "sim.json5")]
        for u in self.ugvs:
            args += ["--ugv", f"{u}:{self.ports[u]}:{sysid[u]}"]
        self._spawn("sim", args)

    def kill(self, name: str, sig: int = signal.SIGKILL) -> None:
        p = self.procs.get(name)
        if p is not None and p.poll() is None:
            self.expected_exit.add(name)
            os.killpg(p.pid, sig)

    def crashed(self) -> list[str]:
        return [n for n, p in self.procs.items() if p.poll() not in (None, 0) and n not in self.expected_exit]

    def stop(self, timeout_s: float = 8.0) -> dict[str, int | None]:
        """SIGTERM in stages, each waited for: the watchers and the simulator, then the localizer and the
        UAV, then the UGVs, then the router; so no service sees a teammate leave and warns of it."""
        stages = [["map", "sim"], ["localizer", self.uav], list(self.ugvs), ["router"]]
        end = time.monotonic() + timeout_s
        for stage in stages:
            for n in stage:
                p = self.procs.get(n)
                if p is not None and p.poll() is None:
                    try:
                        os.killpg(p.pid, signal.SIGTERM)
                    except ProcessLookupError:
                        pass
            for n in stage:
                p = self.procs.get(n)
                if p is None:
                    continue
                try:
                    p.wait(timeout=max(end - time.monotonic(), 0.1))
                except subprocess.TimeoutExpired:
                    os.killpg(p.pid, signal.SIGKILL)
                    p.wait(timeout=5)
        for f in self.logs.values():
            f.close()
        return {n: p.returncode for n, p in self.procs.items()}

    def log_problems(self) -> list[str]:
        """Log files that could not be written in full (a full or failing disk loses the evidence)."""
        free = shutil.disk_usage(self.dir).free
        return [f"{self.dir / 'logs'}: only {free} bytes free"] if free < 1 << 20 else []


    def tail(self, name: str, n: int = 15) -> str:
        try:
            return "\n".join((self.dir / "logs" / f"{name}.log").read_text(errors="replace").splitlines()[-n:])
        except OSError:
            return ""


class Observer:
    """A laptop-side view of the team: crowds scored against the truth, statuses, liveliness."""

    def __init__(self, team: Team) -> None:
        self.team = team
        self.scorer = BusScorer(LocalFrame(team.sc.world.origin_lat_deg, team.sc.world.origin_lon_deg))
        self.lock = threading.Lock()
        self.status: dict[str, Status] = {}
        self.alive: dict[str, bool] = {}

    def on_status(self, key: str, s: Status) -> None:
        with self.lock:
            self.status[s.vehicle] = s

    def on_alive(self, key: str, up: bool) -> None:
        with self.lock:
            self.alive[keys.vehicle_of(key) or key] = up

    def line(self, t_rel: float) -> str:
        """One line of at most 80 columns: the first crowd's position, error and radius; who is alive."""
        with self.scorer.lock:
            last = self.scorer.last
            errors = list(self.scorer.board.errors_m)
        with self.lock:
            up = sum(1 for v, a in self.alive.items() if a and v != "sim")
            known = sum(1 for v in self.alive if v != "sim")
        head = f"t={t_rel:5.1f}s"
        if last is None:
            return f"{head} waiting for the first crowd...  alive {up}/{known}"
        truth, crowds, fs = last
        if not crowds.crowds:
            return f"{head} no crowd ({crowds.quality})  lm {len(crowds.landmarks_used)}  alive {up}/{known}"
        c = crowds.crowds[0]
        err = next((e for r, _, e in fs.matches if r == 0), None)
        more = f" +{len(crowds.crowds) - 1}" if len(crowds.crowds) > 1 else ""
        mean = f"{sum(errors) / len(errors):.2f}" if errors else "-"
        return (f"{head} crowd {c.crowd_id}{more} {c.lat_deg:.6f},{c.lon_deg:.6f} "
                f"err {'-' if err is None else f'{err:.2f}'} r95 {c.radius95_m:.1f} mean {mean} {up}/{known}")

    def summary(self) -> dict:
        board = self.scorer.finish()
        s = summarize([board])
        with self.lock:
            s["metrics"] = {v: dict(st.metrics) for v, st in self.status.items()}
            s["rejected"] = {v: st.rejected for v, st in self.status.items()}
            s["notes"] = {v: st.note for v, st in self.status.items()}
        return s


def run_demo(team: Team, stop: StopFlag, *, live: bool = True, out=sys.stdout,
             record: str | None = None) -> tuple[dict, dict]:
    obs = Observer(team)
    team.start()
    bus = ZenohBus.open(team.member_bus("view"))
    recorder, rec_subs = None, []
    try:
        if record:   # every key of the team and the services' configs, from before the simulator starts
            recorder = McapRecorder(record, team.team, recorder="uvteam demo --record")
            for vid, cfg in team.configs.items():
                recorder.add_config(vid, vehicle_config_to_toml(cfg, f"uvteam demo: {vid} ({cfg.role})"))
            rec_subs = attach_zenoh(bus.session, team.team, recorder)
        bus.subscribe(keys.key(team.team, "sim", "truth"), Truth, obs.scorer.on_truth)
        bus.subscribe(keys.key(team.team, team.localizer, "crowds"), Crowds, obs.scorer.on_crowds)
        bus.subscribe(keys.all_vehicles(team.team, "status"), Status, obs.on_status)
        bus.watch_alive(keys.alive_all(team.team), obs.on_alive)
        # let the services open their sessions before the simulator starts the clock
        end_wait = time.monotonic() + 20.0
        want = {team.localizer, team.uav, *team.ugvs}
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
                    print(f"t={t_rel:5.1f}s scenario event: {u}'s service killed (SIGKILL)", file=out, flush=True)
            if live and t_rel >= next_view:
                print(obs.line(t_rel), file=out, flush=True)
                next_view = t_rel + 1.0
            bad = team.crashed()
            if bad:
                print(f"uvteam demo: {', '.join(bad)} exited unexpectedly:\n" +
                      "\n".join(team.tail(b) for b in bad), file=out, flush=True)
                break
            if team.procs["sim"].poll() is not None:
                break
        time.sleep(1.5)  # the last crowds messages and one more status from every service
    finally:
        codes = team.stop()
        for sub in rec_subs:
            sub.undeclare()
        if recorder is not None:
            recorder.close()
            print(f"recorded {recorder.messages} messages to {record} (open it in Foxglove, or "
                  f"`uvteam replay {record} --localizer`)", file=out, flush=True)
        bus.close()
    return obs.summary(), codes


def _router_args(args) -> tuple[str, ...]:
    """The zenoh flags given to the demo, for the router it starts (the team itself stays on loopback):
    ``-l tcp/0.0.0.0:7447`` lets a laptop on the network watch, ``-e`` joins another router, ``--cfg``
    tunes it."""
    if args.mode not in (None, "router"):
        raise ConfigError("--mode", "mode", f"the demo's flags are for its router, which runs in mode router, "
                                            f"not {args.mode}")
    if args.secure and (args.listen or args.connect or args.cfg or args.zenoh_config):
        raise ConfigError("--secure", "zenoh flags", "the secure profile's router uses its generated config only")
    parse_cfg(args.cfg)
    out: list[str] = []
    for flag, values in (("--listen", args.listen), ("--connect", args.connect), ("--cfg", args.cfg)):
        for v in values:
            out += [flag, v]
    if args.zenoh_config:
        out += ["--zenoh-config", str(Path(args.zenoh_config).resolve())]
    return tuple(out)


def _map_address(wanted: str) -> str:
    """``wanted`` (HOST:PORT) when that port is free on loopback, else the same host on a free port."""
    host, _, port = wanted.rpartition(":")
    if port == "0":
        return f"{host}:{free_port()}"
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET) as s:
        try:
            s.bind((host.strip("[]"), int(port)))
            return wanted
        except (OSError, ValueError):
            pass
    return f"{host}:{free_port()}"


def _table(rows: list[tuple[str, str]]) -> str:
    w = max(len(k) for k, _ in rows)
    return "\n".join(f"  {k:<{w}}  {v}" for k, v in rows)


def print_summary(team: Team, s: dict, codes: dict, out=sys.stdout) -> None:
    f = lambda x, d=3: "-" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{d}f}"  # noqa: E731
    print("\nsummary (crowds vs truth, every frame, as `uvteam experiment` scores):", file=out)
    print(_table([("frames scored", str(s["n"])), ("mean error", f"{f(s['mean_m'])} m"),
                  ("median / p95 / max", f"{f(s['median_m'])} / {f(s['p95_m'])} / {f(s['max_m'])} m"),
                  ("recall after 1 s", f(s["recall"])), ("false crowds (frames)", str(s["false_crowds"])),
                  ("UGV reported as a crowd", str(s["ugv_as_crowd"])),
                  ("inside the 95 % radius", f(s["coverage95"])),
                  ("crowd id changes", str(s["id_changes"]))]), file=out)
    print("\nservices:", file=out)
    print(f"  {'vehicle':<10} {'exit':>5} {'rejected':>9}  metrics", file=out)
    for v in [team.localizer, team.uav, *team.ugvs]:
        m = s["metrics"].get(v, {})
        keep = ("crowds_published", "step_us_p50", "processed", "dropped", "crowds_received", "crowds_latency_p99_ms",
                "plans_published")
        shown = " ".join(f"{k}={m[k]:g}" for k in keep if k in m)
        name = "localizer" if v == team.localizer else v
        print(f"  {v:<10} {str(codes.get(name)):>5} {s['rejected'].get(v, 0):>9}  {shown}", file=out)
    for p in team.log_problems():
        print(f"  warning: {p}", file=out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uvteam demo", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenario", default=str(DEFAULT_SCENARIO), help="scenario TOML (default: the 6-UGV demo)")
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--duration", type=float, default=None, help="seconds (default: the scenario's)")
    ap.add_argument("--quiet", action="store_true", help="no live view, only the summary")
    ap.add_argument("--frames", choices=sorted(FRAMES), default="pixels",
                    help="pixels: the simulator renders camera frames and the UAV service detects on them "
                         "(default); sensor: the simulator's sensor model replaces the UAV's vision")
    ap.add_argument("--json", metavar="FILE", help="also write the summary as JSON")
    ap.add_argument("--record", metavar="FILE.mcap",
                    help="record every key of the team and the services' configs to an MCAP file (uvteam replay, "
                         "Foxglove)")
    ap.add_argument("--workdir", help="where configs and logs go (default: a new temporary folder)")
    ap.add_argument("--map-http", default="127.0.0.1:8770", metavar="HOST:PORT",
                    help="where the live map is served (default 127.0.0.1:8770, or a free port when that is taken; "
                         "port 0: any free port)")
    ap.add_argument("--no-map", action="store_true", help="do not start the live map (uvteam map)")
    ap.add_argument("--secure", action="store_true",
                    help="run under the secure profile: a team CA and certificates (uvteam certs), TLS with client "
                         "certificates, and access control on the router")
    add_bus_args(ap)
    args = ap.parse_args(argv)
    stop = StopFlag()
    try:
        router_args = _router_args(args)
        team = Team(args.scenario, seed=args.seed, duration_s=args.duration, workdir=args.workdir, frames=args.frames,
                    secure=args.secure, map_http=None if args.no_map else _map_address(args.map_http),
                    annotate=not args.no_map, router_args=router_args)
    except (ConfigError, OSError) as exc:
        print(f"uvteam demo: {exc}", file=sys.stderr)
        return 2
    join = ["--zenoh-config", str(team.secrets / "view.json5")] if team.secure else ["--connect", team.endpoint]
    tap = " ".join(uvteam_command() + ["tap", "--summary", "--team", team.team, *join])
    mapcmd = " ".join(uvteam_command() + ["map", "--team", team.team, *join])
    print(f"uvteam demo: {team.sc.name}, {len(team.ugvs)} UGVs, {team.duration_s:.0f} s; router {team.endpoint}\n"
          f"  configs and logs: {team.dir}\n  watch from another terminal: {tap}", flush=True)
    if team.map_url:
        print(f"  live map: open {team.map_url} in a browser"
              + (" (with what the UAV sees beside it)" if team.annotate_url else ""), flush=True)
    else:
        print(f"  or on a map (then open http://127.0.0.1:8770/): {mapcmd}", flush=True)
    summary, codes = run_demo(team, stop, live=not args.quiet, record=args.record)
    print_summary(team, summary, codes)
    if args.json:
        try:
            Path(args.json).write_text(json.dumps({"summary": summary, "exit_codes": codes}, indent=2))
        except OSError as exc:
            print(f"uvteam demo: cannot write {args.json}: {exc}", file=sys.stderr)
            return 1
    bad = [n for n, c in codes.items() if c not in (0, None, -signal.SIGTERM) and n not in team.expected_exit]
    return 1 if bad or summary["n"] == 0 or team.log_problems() else 0
