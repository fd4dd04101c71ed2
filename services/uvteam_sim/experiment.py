"""`uvteam experiment`: run scenario files over their seeds in-process and score them.

The same core code as the deployed services (planner, localizer step, crowd tracker) runs in
simulated time against :class:`SimWorld`; only the bus and the MAVLink links are left out. Scoring
follows ../shared/scenarios/README.md: per frame with a crowd present and reported, the ground
distance between the reported position and the true centroid; reports matched to true crowds by
Hungarian assignment with a 10 m gate; unmatched reports are false crowds, unmatched true crowds
misses; mingling crowds scored as one.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import os
import sys
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

from uvteam.camera import PinholeCamera
from uvteam.crowds import GroupingConfig, GroupingState, report_crowds
from uvteam.detector_noise import localizer_sigmas_px
from uvteam.localizer import FrameObservation, LocalizerConfig, LocalizerState, UgvTrack, localize_step
from uvteam.planning import plan_stations
from uvteam.io.files import load_scenario
from uvteam.scenario import Scenario

from .world import SimWorld

__all__ = ["RunResult", "run_scenario_seed", "summarize", "main", "TEAM_DEFAULTS"]

TRACKING_INTERVAL_S = 1.0
CONFIRM_HITS = 3            # a crowd is published once its track has been seen this many times
SCORE_GATE_M = 10.0
CROWD_STALE_S = 5.0         # as the UGV service: an older crowd estimate is not planned around
T0 = 1_700_000_000.0        # simulated UNIX epoch of every run's start
TEAM_DEFAULTS = {"gate_px": 25.0}


@dataclass
class RunResult:
    scenario: str
    seed: int
    times_s: list = field(default_factory=list)     # per matched (frame, crowd)
    errors_m: list = field(default_factory=list)
    radius95_m: list = field(default_factory=list)
    quality: list = field(default_factory=list)
    truth_frames: int = 0                            # (frame, true crowd) pairs after the first second
    detected_frames: int = 0
    false_crowds: int = 0
    ugv_as_crowd: int = 0
    frames: int = 0
    frame_log: list = field(default_factory=list)    # per frame: (t, true crowds, matched, reported)
    false_log: list = field(default_factory=list)    # per false crowd: (t, east m, north m, distance to nearest UGV m)


def _ugv_ids(sc: Scenario) -> list[str]:
    return [f"ugv{i + 1}" for i in range(sc.ugvs.count)]


def detector_sigmas_px(sc: Scenario, detector: str, image_coordinates: str) -> tuple[float, float]:
    """(landmark, target) 1-sigma pixel noise the localizer assumes for this detector in this scenario."""
    f = PinholeCamera(sc.camera.width_px, sc.camera.height_px, sc.camera.hfov_deg).focal_px
    return localizer_sigmas_px(detector, image_coordinates, sc.uav.altitude_agl_m, f)


def localizer_config(sc: Scenario, frame, image_coordinates: str | None = None, detector: str = "sensor") -> LocalizerConfig:
    ic = image_coordinates or sc.landmarks.image_coordinates
    s_lm, s_tg = detector_sigmas_px(sc, detector, ic)
    return LocalizerConfig(
        frame=frame, gate_px=TEAM_DEFAULTS["gate_px"], tracking_interval_s=TRACKING_INTERVAL_S,
        image_coordinates=ic, sigma_landmark_px=s_lm, sigma_target_px=s_tg,
        fix_extrapolate_s=max(0.3, 1.5 / sc.gnss.fix_rate_hz + sc.gnss.latency_s))


def run_scenario_seed(sc: Scenario, seed: int, *, detector=None, image_coordinates: str | None = None) -> RunResult:
    """One seed of one scenario. ``detector(world, pose, stamp_s) -> SensorFrame`` (default: the
    sensor model) lets the vision pipeline replace the sensor model."""
    world = SimWorld(sc, seed)
    cfg = localizer_config(sc, world.frame, image_coordinates, getattr(detector, "kind", "sensor"))
    ids = _ugv_ids(sc)
    color_to_id = dict(zip(sc.ugvs.colors, ids))
    lost_at = {int(i): float(t) for i, t in sc.events.lose_ugv}
    fixes = {u: deque(maxlen=64) for u in ids}
    plans: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    pending: list[tuple[float, int, float, np.ndarray, float]] = []
    state, grouping = LocalizerState(), GroupingState()
    res = RunResult(sc.name, seed)
    dt_frame = 1.0 / sc.run.frame_rate_hz
    dt_fix = 1.0 / sc.gnss.fix_rate_hz
    n_frames = int(round(sc.run.duration_s * sc.run.frame_rate_hz))
    substeps = 4
    next_fix = 0.0
    next_plan = 0.0
    crowd_est: tuple[np.ndarray, np.ndarray, float] | None = None
    last_uav: tuple[np.ndarray, float] | None = None
    fw, fh = world.camera.footprint_m(sc.uav.altitude_agl_m)
    sense = detector or (lambda w, pose, stamp: w.sense(pose, stamp))
    for f in range(n_frames + 1):
        t = f * dt_frame
        alive = [i for i in range(len(ids)) if t < lost_at.get(i, math.inf)]
        # GNSS fixes (captured now, delivered latency_s later)
        while next_fix <= t + 1e-9:
            for i in alive:
                if not world.in_dropout(i, next_fix):
                    h_acc = math.sqrt(sc.gnss.sigma_m ** 2 + sc.gnss.bias_walk_m_per_sqrt_s ** 2 * min(next_fix, 60.0))
                    pending.append((next_fix + sc.gnss.latency_s, i, next_fix,
                                    (world.ugv_fix_en(i), world.ugv_fix_v(i)), h_acc))
            next_fix += dt_fix
        keep = []
        for rel, i, cap, en, h_acc in pending:
            if rel <= t + 1e-9:
                fixes[ids[i]].append((T0 + cap, en[0], h_acc, en[1]))
            else:
                keep.append((rel, i, cap, en, h_acc))
        pending = keep
        # UGV planners, once per tracking interval, from what they know (fixes and published crowds)
        if t >= next_plan - 1e-9:
            known = {ids[i]: fixes[ids[i]][-1][1] for i in alive if fixes[ids[i]]}
            if known:
                # as the UGV service: the published crowd, else the point under the UAV (its fix)
                uav_en = world.uav_p + world.wobble
                uav_v = (uav_en - last_uav[0]) / max(t - last_uav[1], 1e-6) if last_uav is not None else np.zeros(2)
                last_uav = (uav_en.copy(), t)
                if crowd_est is not None and t - crowd_est[2] < CROWD_STALE_S:
                    centre, vel = crowd_est[0] + crowd_est[1] * (t - crowd_est[2]), crowd_est[1]
                else:
                    centre, vel = uav_en, uav_v
                sp = plan_stations(centre, vel, known, T0 + t, radius_m=sc.ugvs.station_radius_m,
                                   view_half_m=(fw / 2, fh / 2), horizon_s=3 * TRACKING_INTERVAL_S,
                                   step_s=TRACKING_INTERVAL_S, max_speed_m_s=sc.ugvs.approach_speed_m_s)
                for u, p in sp.items():
                    i = ids.index(u)
                    world.set_mission(i, [(float(e), float(n), float(s)) for (e, n), s in zip(p.en_m, p.speed_m_s)])
                    plans[u] = (p.stamp_s, p.en_m)
            next_plan += TRACKING_INTERVAL_S
        # the UAV frame
        pose = world.camera_pose()
        sf = sense(world, pose, T0 + t)
        obs = FrameObservation(T0 + t, {color_to_id[c]: xy for c, xy in sf.landmarks.items()},
                               sf.blob_xy_px, sf.blob_xyxy_px, tuple(color_to_id.get(c, "") for c in sf.blob_color),
                               sf.blob_area_px)
        tracks = {}
        for u in ids:
            if not fixes[u]:
                continue
            st = np.array([x[0] for x in fixes[u]])
            en = np.array([x[1] for x in fixes[u]])
            sg = np.array([x[2] for x in fixes[u]])
            vel = np.array([x[3] for x in fixes[u]])
            ps, pe = plans.get(u, (np.empty(0), np.empty((0, 2))))
            if ids.index(u) in lost_at and t >= lost_at[ids.index(u)]:
                ps, pe = np.empty(0), np.empty((0, 2))  # its service is gone: no new plans either
            tracks[u] = UgvTrack(st, en, sg, ps, pe, vel)
        state, out = localize_step(state, obs, tracks, cfg)
        grouping, confirmed = report_crowds(grouping, out.crowds, T0 + t, world.frame, GroupingConfig(confirm_hits=CONFIRM_HITS))
        if confirmed:
            best = confirmed[0]  # the longest-seen crowd, as the UGV service follows
            crowd_est = (np.array([best[0].east_m, best[0].north_m]),
                         np.array([best[1].v_east_m_s, best[1].v_north_m_s]), t)
        # scoring
        truth = world.truth_crowds()
        res.frames += 1
        rep = np.array([[c.east_m, c.north_m] for c, _ in confirmed]).reshape(-1, 2)
        tru = np.array([c for c, _ in truth]).reshape(-1, 2)
        matched_rep, matched_tru = set(), set()
        if len(rep) and len(tru):
            d = np.sqrt(((rep[:, None] - tru[None]) ** 2).sum(-1))
            ri, ci = linear_sum_assignment(d)
            for r_, c_ in zip(ri, ci):
                if d[r_, c_] <= SCORE_GATE_M:
                    matched_rep.add(r_)
                    matched_tru.add(c_)
                    res.times_s.append(t)
                    res.errors_m.append(float(d[r_, c_]))
                    res.radius95_m.append(confirmed[r_][0].radius95_m)
                    res.quality.append(confirmed[r_][0].quality.value)
        for r_ in range(len(rep)):
            if r_ not in matched_rep:
                res.false_crowds += 1
                ugv_d = np.sqrt(((world.ugv_p - rep[r_]) ** 2).sum(1)).min()
                if ugv_d < 2.0:
                    res.ugv_as_crowd += 1
                res.false_log.append((t, float(rep[r_, 0]), float(rep[r_, 1]), float(ugv_d)))
        res.frame_log.append((t, len(tru), len(matched_tru), len(rep)))
        if t >= 1.0:
            res.truth_frames += len(tru)
            res.detected_frames += len(matched_tru)
        for _ in range(substeps):
            world.step(dt_frame / substeps)
    return res


def summarize(results: list[RunResult]) -> dict:
    e = np.concatenate([np.asarray(r.errors_m, float) for r in results]) if results else np.empty(0)
    r95 = np.concatenate([np.asarray(r.radius95_m, float) for r in results]) if results else np.empty(0)
    tf = sum(r.truth_frames for r in results)
    return {
        "n": int(len(e)),
        "mean_m": float(e.mean()) if len(e) else math.nan,
        "median_m": float(np.median(e)) if len(e) else math.nan,
        "p95_m": float(np.percentile(e, 95)) if len(e) else math.nan,
        "max_m": float(e.max()) if len(e) else math.nan,
        "recall": sum(r.detected_frames for r in results) / tf if tf else math.nan,
        "false_crowds": sum(r.false_crowds for r in results),
        "ugv_as_crowd": sum(r.ugv_as_crowd for r in results),
        "coverage95": float(np.mean(e <= r95)) if len(e) else math.nan,
    }


def _run_job(job: tuple[str, int, str]) -> RunResult:
    path, seed, detector = job
    import cv2  # noqa: PLC0415

    cv2.setNumThreads(1)  # one core per run: the runs themselves are the parallelism
    det = None
    if detector == "pixels":
        from .pixels import pixel_detector  # noqa: PLC0415

        det = pixel_detector()
    return run_scenario_seed(load_scenario(path), seed, detector=det)


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
    lines = ["| scenario | variant | frames scored | mean m | median m | p95 m | max m | paper mean m | recall | false crowds | UGV as crowd | in 95% radius |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for sc, variant, s in rows:
        paper = "-" if math.isnan(sc.paper_mean_error_m) else f"{sc.paper_mean_error_m:.2f}"
        lines.append(f"| {sc.name} | {variant} | {s['n']} | {s['mean_m']:.3f} | {s['median_m']:.3f} | {s['p95_m']:.3f} | "
                     f"{s['max_m']:.3f} | {paper} | {s['recall']:.3f} | {s['false_crowds']} | {s['ugv_as_crowd']} | "
                     f"{s['coverage95']:.3f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uvteam experiment", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenarios", nargs="+", help="scenario TOML files, e.g. ../shared/scenarios/*.toml")
    ap.add_argument("--seeds", type=int, default=None, help="use only the first N seeds of each scenario")
    ap.add_argument("--detector", choices=["sensor", "pixels"], default="sensor",
                    help="sensor: the simulator's sensor model; pixels: rendered frames through the vision pipeline")
    ap.add_argument("--out", default="out/experiment", help="folder for the Markdown table and PNG plots")
    ap.add_argument("--jobs", type=int, default=max(1, (os.cpu_count() or 1)),
                    help="runs in parallel, one process each (default: one per core)")
    args = ap.parse_args(argv)
    scenarios = [load_scenario(p) for p in args.scenarios]
    per: dict[str, list[RunResult]] = {}
    t0 = time.perf_counter()
    work = [(str(p), seed, args.detector) for p, sc in zip(args.scenarios, scenarios)
            for seed in (sc.run.seeds[: args.seeds] if args.seeds else sc.run.seeds)]
    _progress(0, len(work), "")
    if args.jobs > 1:
        with multiprocessing.get_context("spawn").Pool(args.jobs) as pool:
            for k, res in enumerate(pool.imap_unordered(_run_job, work), start=1):
                per.setdefault(res.scenario, []).append(res)
                _progress(k, len(work), f"{res.scenario} seed {res.seed}")
    else:
        for k, job in enumerate(work, start=1):
            res = _run_job(job)
            per.setdefault(res.scenario, []).append(res)
            _progress(k, len(work), f"{res.scenario} seed {res.seed}")
    for v in per.values():
        v.sort(key=lambda r: r.seed)
    rows = [(sc, f"{args.detector}, {sc.landmarks.image_coordinates} landmarks", summarize(per[sc.name])) for sc in scenarios]
    md = table_markdown(rows)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.md").write_text(md + "\n")
    print(md)
    print(f"\n{len(work)} runs in {time.perf_counter() - t0:.1f} s; table in {out / 'results.md'}")
    from .plots import write_plots  # noqa: PLC0415

    try:
        for path in write_plots(per, scenarios, out, args.detector):
            print(f"plot: {path}")
    except ImportError as exc:
        print(f"no plots ({exc}); install the plots extra: pip install -e '.[plots]'", file=sys.stderr)
    return 0
