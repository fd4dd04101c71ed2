"""`uvteam experiment`: run scenario files over their seeds in-process and score them.

Each run is the deployed team's own code: the service classes (:mod:`uvteam.nodes`: UAV, localizer,
one per UGV) with the configs an operator would write (:func:`uvteam.team.team_configs`: shipped
defaults plus the team's ids and colors), over the in-memory bus, in simulated time. The simulator
plays every autopilot (a :class:`uvteam.autopilot.MemoryAutopilot` per vehicle, fed by
:class:`.simulation.Simulation`) and the UAV camera (rendered frames, or the sensor model's
detections on the ``sensor`` key). Only the transports differ from the demo: no zenoh, no MAVLink.

Scoring is :mod:`uvteam.scoring` on the ``truth`` and ``crowds`` messages, as in the demo. Each run's
result is written as it finishes (``<out>/runs/``); ``--resume`` keeps those already there, so an
interrupted experiment loses nothing; an output folder that cannot be written is an error (exit 2)
before anything runs. The table (``results.md``) ends with, and ``environment.json`` holds, the Python
and library versions its figures were measured with.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import os
import platform
import sys
import time
from dataclasses import asdict, replace
from importlib import metadata
from pathlib import Path

from uvteam import keys
from uvteam.autopilot import MemoryAutopilot
from uvteam.bus import InMemoryBus
from uvteam.errors import ConfigError
from uvteam.io.files import ImageryMissing, load_scenario
from uvteam.messages import Crowds, Truth
from uvteam.nodes.localizer import LocalizerNode
from uvteam.nodes.uav import UavNode
from uvteam.nodes.ugv import UgvNode
from uvteam.scenario import Scenario
from uvteam.scoring import BusScorer, Scoreboard, summarize
from uvteam.team import TeamLayout, team_configs

from .simulation import Simulation

__all__ = ["RunResult", "SimTeam", "run_scenario_seed", "summarize", "main", "T0"]

T0 = 1_700_000_000.0        # simulated UNIX epoch of every run's start
DETECTORS = {"sensor": "sim-sensor", "pixels": "pixels"}
RunResult = Scoreboard


class SimClock:
    """Simulated UNIX time, set by the run loop."""

    def __init__(self, t_s: float) -> None:
        self.t_s = t_s

    def __call__(self) -> float:
        return self.t_s


class SimTeam:
    """The team's service nodes over one in-memory bus, driven tick by tick by a :class:`Simulation`.

    Per tick, in this order (each node's own phases, :mod:`uvteam.nodes`): lost UGVs' services stopped
    (liveliness dropped); fixes delivered to the UGVs' autopilots (and on a frame, the UAV's state);
    every vehicle publishes its fix; every UGV plans (once per tracking interval) and exchanges its
    mission; on a frame: the frame (rendered pixels through the UAV node's vision, or the sensor
    model's detections on the bus), the truth, and the localizer's step."""

    def __init__(self, sc: Scenario, seed: int, detector: str = "sensor", team: str = "exp") -> None:
        self.sc, self.seed, self.detector = sc, seed, detector
        self.layout = TeamLayout.for_scenario(sc, team)
        self.cfgs = team_configs(sc, self.layout, detector=DETECTORS[detector])
        self.sim = Simulation(sc, seed, T0)
        self.clock = SimClock(T0)
        self.hub = InMemoryBus()
        lay = self.layout
        self.loc = LocalizerNode(self.cfgs[lay.localizer], self._bus(lay.localizer), self.clock)
        self.uav_ap = MemoryAutopilot()
        self.uav = UavNode(self.cfgs[lay.uav], self._bus(lay.uav), self.uav_ap, self.clock)
        self.ugv_aps = [MemoryAutopilot(on_mission=lambda items, i=i: self.sim.set_mission(i, items))
                        for i in range(len(lay.ugvs))]
        self.ugvs: dict[str, UgvNode] = {u: UgvNode(self.cfgs[u], self._bus(u), self.ugv_aps[i], self.clock)
                                         for i, u in enumerate(lay.ugvs)}
        for node in [self.loc, self.uav, *self.ugvs.values()]:
            node.start()
        self.sim_bus = InMemoryBus(self.hub)
        self.scorer = BusScorer(self.sim.world.frame, Scoreboard(sc.name, seed))
        self.sim_bus.subscribe(keys.key(lay.team, "sim", "truth"), Truth, self.scorer.on_truth)
        self.sim_bus.subscribe(keys.key(lay.team, lay.localizer, "crowds"), Crowds, self.scorer.on_crowds)
        self.renderer = None
        if detector == "pixels":
            import numpy as np  # noqa: PLC0415

            from .render import Renderer  # noqa: PLC0415

            self.renderer = Renderer(self.sim.world, np.random.default_rng([seed, 0x5EE]))

    def _bus(self, vehicle: str) -> InMemoryBus:
        bus = InMemoryBus(self.hub)
        bus.declare_alive(keys.alive(self.layout.team, vehicle))
        return bus

    def lose(self, i: int) -> None:
        """UGV ``i``'s service stops for good: its subscriptions and liveliness go."""
        u = self.layout.ugvs[i]
        node = self.ugvs.pop(u, None)
        if node is not None:
            node.bus.close()
            node.bus.drop_alive(keys.alive(self.layout.team, u))

    def run(self, duration_s: float | None = None) -> Scoreboard:
        lay, sim = self.layout, self.sim
        truth_key = keys.key(lay.team, "sim", "truth")
        sensor_key = keys.key(lay.team, lay.uav, "sensor")
        for tick in sim.ticks(duration_s):
            self.clock.t_s = T0 + tick.t_s
            for i in tick.lost:
                self.lose(i)
            for f in tick.fixes:
                self.ugv_aps[f.ugv_index].set_state(f.state)
            pose = None
            if tick.frame_seq is not None:   # the UAV's autopilot reports where the camera is at the frame
                pose = sim.world.camera_pose()
                self.uav_ap.set_state(sim.uav_state(pose, tick.t_s))
            for node in (*self.ugvs.values(), self.uav):
                node.publish_fix()
            for node in self.ugvs.values():
                node.tick(self.clock.t_s)
                node.exchange_mission()
            if pose is None:
                continue
            if self.renderer is not None:
                self.uav.process_frame(self.clock.t_s, tick.frame_seq, self.renderer.render(pose))
            else:
                self.sim_bus.publish(sensor_key, sim.sensor_detections(pose, tick.t_s, tick.frame_seq, lay.uav))
            self.sim_bus.publish(truth_key, sim.truth(tick.t_s, tick.frame_seq, list(lay.ugvs)))
            self.loc.step(0.0)
        return self.scorer.finish()


def run_scenario_seed(sc: Scenario, seed: int, *, detector: str = "sensor", image_coordinates: str | None = None,
                      duration_s: float | None = None) -> Scoreboard:
    """One seed of one scenario through the team's own code (``detector``: "sensor" or "pixels")."""
    if image_coordinates is not None:
        sc = replace(sc, landmarks=replace(sc.landmarks, image_coordinates=image_coordinates))
    return SimTeam(sc, seed, detector).run(duration_s)


def _run_job(job: tuple[str, int, str]) -> Scoreboard:
    path, seed, detector = job
    import cv2  # noqa: PLC0415

    cv2.setNumThreads(1)  # one core per run: the runs themselves are the parallelism
    return run_scenario_seed(load_scenario(path), seed, detector=detector)


def _progress(done: int, total: int, label: str) -> None:
    if not sys.stderr.isatty():
        if done:
            print(f"[{done}/{total}] {label}", file=sys.stderr, flush=True)
        return
    w = 30
    k = int(w * done / max(total, 1))
    sys.stderr.write(f"\r[{'#' * k}{'.' * (w - k)}] {done}/{total} {label:<40}")
    sys.stderr.flush()
    if done == total:
        sys.stderr.write("\n")


def table_markdown(rows: list[tuple[Scenario, str, dict]]) -> str:
    lines = ["| scenario | variant | frames scored | mean m | median m | p95 m | max m | paper mean m | recall | "
             "of them predicted | false crowds | UGV as crowd | in 95% radius | id changes |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for sc, variant, s in rows:
        paper = "-" if math.isnan(sc.paper_mean_error_m) else f"{sc.paper_mean_error_m:.2f}"
        lines.append(f"| {sc.name} | {variant} | {s['n']} | {s['mean_m']:.3f} | {s['median_m']:.3f} | {s['p95_m']:.3f} | "
                     f"{s['max_m']:.3f} | {paper} | {s['recall']:.3f} | {s['predicted']} | {s['false_crowds']} | "
                     f"{s['ugv_as_crowd']} | "
                     f"{s['coverage95']:.3f} | {s['id_changes']} |")
    return "\n".join(lines)


def _run_path(out: Path, scenario: str, seed: int, detector: str) -> Path:
    return out / "runs" / f"{scenario}__{detector}__seed{seed}.json"


def _save_run(path: Path, board: Scoreboard) -> None:
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(asdict(board)))
    os.replace(tmp, path)


def _load_run(path: Path) -> Scoreboard | None:
    try:
        return Scoreboard(**json.loads(path.read_text()))
    except (OSError, ValueError, TypeError):
        return None


def _writable(out: Path) -> str | None:
    try:
        (out / "runs").mkdir(parents=True, exist_ok=True)
        probe = out / "runs" / ".write-test"
        probe.write_text("x" * 4096)
        probe.unlink()
    except OSError as exc:
        return f"{out}: cannot write results there: {exc.strerror or exc}"
    return None


# The libraries a table's figures depend on: the same code gives other figures with other versions
# (opencv's LK and RANSAC, numpy's and scipy's numerics), and pyproject gives ranges, not pins.
FIGURE_LIBRARIES = ("opencv-python-headless", "numpy", "scipy", "msgpack", "eclipse-zenoh", "pymavlink")


def environment() -> dict:
    """What produced an experiment's figures: Python, the libraries in FIGURE_LIBRARIES (None: not
    installed) and the machine, written beside its table."""
    def version(name: str) -> str | None:
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:
            return None

    return {"python": platform.python_version(), "machine": platform.machine(), "cpus": os.cpu_count(),
            "libraries": {name: version(name) for name in FIGURE_LIBRARIES}}


def environment_line(env: dict) -> str:
    """The table's footnote: the versions its figures were measured with."""
    libs = ", ".join(f"{k} {v}" for k, v in env["libraries"].items() if v is not None)
    return f"Measured with Python {env['python']}, {libs} ({env['machine']}, {env['cpus']} CPUs)."


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uvteam experiment", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenarios", nargs="+", help="scenario TOML files, e.g. ../shared/scenarios/*.toml")
    ap.add_argument("--seeds", type=int, default=None, help="use only the first N seeds of each scenario")
    ap.add_argument("--seed", type=int, action="append", default=None, metavar="N",
                    help="use these seeds instead of the scenario's (repeatable): score on seeds not tuned on")
    ap.add_argument("--detector", choices=sorted(DETECTORS), default="sensor",
                    help="sensor: the simulator's sensor model; pixels: rendered frames through the UAV's vision")
    ap.add_argument("--out", default="out/experiment", help="folder for the Markdown table, PNG plots and per-run results")
    ap.add_argument("--resume", action="store_true", help="keep the per-run results already in --out")
    ap.add_argument("--jobs", type=int, default=max(1, (os.cpu_count() or 1)),
                    help="runs in parallel, one process each (default: one per core)")
    args = ap.parse_args(argv)
    paths, scenarios = [], []
    try:
        for p in args.scenarios:
            try:
                scenarios.append(load_scenario(p))
                paths.append(p)
            except ImageryMissing as exc:   # real imagery is never in the repository: skip, say so
                print(f"uvteam experiment: skipping {p}: {exc.key}: {exc.reason}", file=sys.stderr)
    except ConfigError as exc:
        print(f"uvteam experiment: {exc}", file=sys.stderr)
        return 2
    if not scenarios:
        print("uvteam experiment: no scenario left to run", file=sys.stderr)
        return 2
    out = Path(args.out)
    why = _writable(out)
    if why:
        print(f"uvteam experiment: {why}", file=sys.stderr)
        return 2
    per: dict[str, list[Scoreboard]] = {}
    t0 = time.perf_counter()
    work = []
    for p, sc in zip(paths, scenarios):
        seeds = args.seed or (sc.run.seeds[: args.seeds] if args.seeds else sc.run.seeds)
        for seed in seeds:
            done = _load_run(_run_path(out, sc.name, seed, args.detector)) if args.resume else None
            if done is not None:
                per.setdefault(sc.name, []).append(done)
            else:
                work.append((str(p), seed, args.detector))
    _progress(0, len(work), "")

    def finished(k: int, res: Scoreboard) -> None:
        _save_run(_run_path(out, res.scenario, res.seed, args.detector), res)
        per.setdefault(res.scenario, []).append(res)
        _progress(k, len(work), f"{res.scenario} seed {res.seed}")

    try:
        if args.jobs > 1 and len(work) > 1:
            with multiprocessing.get_context("spawn").Pool(args.jobs) as pool:
                for k, res in enumerate(pool.imap_unordered(_run_job, work), start=1):
                    finished(k, res)
        else:
            for k, job in enumerate(work, start=1):
                finished(k, _run_job(job))
    except OSError as exc:
        print(f"uvteam experiment: writing a run's result failed: {exc}; the runs written so far are in "
              f"{out / 'runs'} (--resume keeps them)", file=sys.stderr)
        return 2
    for v in per.values():
        v.sort(key=lambda r: r.seed)
    rows = [(sc, f"{args.detector}, {sc.landmarks.image_coordinates} landmarks", summarize(per.get(sc.name, [])))
            for sc in scenarios]
    env = environment()
    md = table_markdown(rows) + "\n\n" + environment_line(env)
    try:
        (out / "environment.json").write_text(json.dumps(env, indent=1) + "\n")
        (out / "results.md").write_text(md + "\n")
    except OSError as exc:
        print(md)
        print(f"uvteam experiment: cannot write {out / 'results.md'}: {exc}", file=sys.stderr)
        return 2
    print(md)
    print(f"\n{len(work)} runs in {time.perf_counter() - t0:.1f} s; table in {out / 'results.md'}")
    from .plots import write_plots  # noqa: PLC0415

    try:
        for path in write_plots(per, scenarios, out, args.detector):
            print(f"plot: {path}")
    except ImportError as exc:
        print(f"no plots ({exc}); install the plots extra: pip install -e '.[plots]'", file=sys.stderr)
    return 0
