"""Speed of one localizer step, side by side: the step as it is, the step as it was, and a bare OpenCV fit.

Three things are timed in one process, interleaved round by round (the machine's speed drifts between
runs and its cores are shared, so only figures taken together compare):

- ``now``: :func:`uvteam.localizer.localize_step`, the product;
- ``before``: the same step as it was before it was made faster (frozen copies of the four modules in
  ``tests/reference/localize_4d30179``: test code, so only from a source checkout; an installed
  package times ``now`` against ``cv2`` alone);
- ``cv2``: the yardstick: ``cv2.findHomography`` (all landmarks, least squares) and
  ``cv2.perspectiveTransform`` of the points the step maps (each blob's centre and its box's corners).
  It does none of the step's work besides (no pairing, no outliers, no radius, no UGV claims).

The scene: a UAV camera 50 m up (1280x720, 78 deg), six UGVs on a 12 m ring driving at 1 m/s with
10 Hz fixes that report their velocity, their roof labels and motion blobs where the camera sees them,
and crowd blobs scattered in the rest of the image; 30 frames a second. The detections declare what the
pixel pipeline declares (``--detector pixels``, the deployed path: a crowd blob's offset all steady, the
rest measured in flight, so the step also propagates the fixes' part of each radius) or what the
simulator's sensor model does (``--detector sensor``: all per frame). Before timing, both steps run
over the same frames and must give the same results (to 1e-9 m): a faster step that is not the same
step is not measured.

Medians over the rounds, of wall-clock time and of this process's CPU time (steadier when other
processes share the core). Run on one core: ``uvteam bench localize`` pins itself; by hand,
``nice taskset -c 1 python -m uvteam_ground.bench_localize``.
"""

from __future__ import annotations

import argparse
import datetime
import gc
import importlib
import os
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

FPS = 30.0
CYCLE_S = 1.0            # the frames repeat every second of scene time, shifted so that time goes on
RING_M = 12.0
UGV_SPEED_M_S = 1.0
UGV_BLOB_M2 = 8.0        # a UGV's own motion blob: median 7.2 and 9.0 m2 in the pixel pipeline's runs (real-alt60-lm6,
                         # paper-fig7-alt50, seed 1), over the localizer's min_vehicle_blob_m2: a vehicle, not a piece
CROWD_OFF_UGV_PX = 90    # crowd blobs lie beyond every UGV's claim (2.5 m and its fix's 95 % error, 1.2 m: 59 px
                         # at 15.8 px/m) and its fixes' noise: the step claims only the UGVs' own blobs


def scene(n_blobs: int, seed: int = 0, detector: str = "pixels"):
    """(tracks, frames): one second of the scene (``FPS`` frames) with ``n_blobs`` blobs each, six of them UGVs,
    with the noise the ``detector`` ("pixels" or "sensor") declares."""
    from uvteam.blobs import Blobs, Landmarks  # noqa: PLC0415
    from uvteam.camera import CameraPose, PinholeCamera, project  # noqa: PLC0415
    from uvteam.detector_noise import SENSOR_MODEL_NOISE, pixel_pipeline_noise  # noqa: PLC0415
    from uvteam.geo import LocalFrame  # noqa: PLC0415
    from uvteam.localizer import FrameObservation, UgvTrack  # noqa: PLC0415
    from uvteam.messages import CameraPoseReport  # noqa: PLC0415
    from uvteam.pose import pose_prior  # noqa: PLC0415

    rng = np.random.default_rng(seed)
    cam = PinholeCamera(1280, 720, 78.0)
    frame = LocalFrame(31.4850, -111.5440)
    lat, lon = frame.ground_to_wgs84(np.array([0.0]), np.array([0.0]))
    report = CameraPoseReport(float(lat[0]), float(lon[0]), 50.0, 0.0, 0.0, 10.0, 1.0, 1.0, 2.0, 0.5)
    pose = CameraPose(0.0, 0.0, 50.0, yaw_deg=10.0)
    prior = pose_prior(report, frame, cam.width_px, cam.height_px, cam.focal_px)
    noise = {"pixels": pixel_pipeline_noise(pose.up_m, cam.focal_px), "sensor": SENSOR_MODEL_NOISE}[detector]
    names = [f"ugv{i + 1}" for i in range(6)]
    ang = np.linspace(0, 2 * np.pi, 6, endpoint=False)
    start = RING_M * np.column_stack([np.sin(ang), np.cos(ang)])
    vel = UGV_SPEED_M_S * np.column_stack([np.cos(ang), -np.sin(ang)])     # along the ring
    fix_t = np.arange(0.0, 1.8 + 1e-9, 0.1)         # the last frames are extrapolated past the newest fix
    tracks = {u: UgvTrack(fix_t, start[i] + np.outer(fix_t, vel[i]) + rng.normal(0, 0.3, (len(fix_t), 2)),
                          np.full(len(fix_t), 0.5), fix_v_en_m_s=np.tile(vel[i], (len(fix_t), 1)))
              for i, u in enumerate(names)}
    n_crowd = max(n_blobs - 6, 0)
    frames = []
    for k in range(int(FPS * CYCLE_S)):
        t = 1.0 + k / FPS
        ugv_px = project(cam, pose, start + vel * t)
        cand = rng.uniform([20, 20], [1260, 700], (4 * n_crowd + 200, 2))
        far = np.sqrt(((cand[:, None] - ugv_px[None]) ** 2).sum(-1)).min(1) > CROWD_OFF_UGV_PX if n_crowd < 1000 else \
            np.min([np.hypot(*(cand - p).T) for p in ugv_px], axis=0) > CROWD_OFF_UGV_PX
        xy = np.vstack([ugv_px + rng.normal(0, 1.0, (6, 2)), cand[far][:n_crowd]])
        area, half = np.full(len(xy), 50.0), np.full((len(xy), 1), 12.0)
        area[:6] = UGV_BLOB_M2 * (cam.focal_px / pose.up_m) ** 2
        half[:6] = np.sqrt(area[:6, None]) / 2          # a square box of the blob's area
        blobs = Blobs(xy, np.column_stack([xy - half, xy + half]), area)
        labels = Landmarks(tuple(names), ugv_px + rng.normal(0, 0.5, (6, 2)))
        frames.append(FrameObservation(t, labels, blobs, noise.color_px, noise.ugv_blob_px, noise.crowd_blob_px, prior,
                                       cam.focal_px / pose.up_m, noise.crowd_blob_frame_px))
    return tracks, frames


def shifted(tracks, frames, cycle: int):
    """The scene ``cycle`` seconds later: the same frames and fixes, their stamps moved on."""
    dt = cycle * CYCLE_S
    return ({u: replace(tr, fix_stamp_s=tr.fix_stamp_s + dt) for u, tr in tracks.items()},
            [replace(f, stamp_s=f.stamp_s + dt) for f in frames])


def _cv2_step(cv2, lm_px: np.ndarray, lm_en: np.ndarray, pts: np.ndarray) -> np.ndarray:
    H, _ = cv2.findHomography(lm_px, lm_en, 0)
    return cv2.perspectiveTransform(pts, H)


def same_results(before, now, tracks, frames, cfg_before, cfg_now, cycles: int = 3) -> tuple[int, float]:
    """Run both steps over ``cycles`` seconds of frames; (crowds compared, largest difference in m).
    Raises AssertionError at the first result that is not the same."""
    s0, s1 = before.LocalizerState(), now.LocalizerState()
    n, worst = 0, 0.0
    for c in range(cycles):
        tr, fr = shifted(tracks, frames, c)
        for obs in fr:
            s0, a = before.localize_step(s0, obs, tr, cfg_before)
            s1, b = now.localize_step(s1, obs, tr, cfg_now)
            assert (a.quality, a.landmarks_used, a.outlier_landmarks, a.blob_of_ugv, a.position_source) == \
                (b.quality, b.landmarks_used, b.outlier_landmarks, b.blob_of_ugv, b.position_source), obs.stamp_s
            assert len(a.crowds) == len(b.crowds), obs.stamp_s
            for x, y in zip(a.crowds, b.crowds):
                assert (x.blob_index, x.quality, x.n_outliers) == (y.blob_index, y.quality, y.n_outliers)
                d = max(abs(x.east_m - y.east_m), abs(x.north_m - y.north_m), abs(x.radius95_m - y.radius95_m),
                        float(np.abs(x.footprint_en_m - y.footprint_en_m).max()))
                assert d <= 1e-9, (obs.stamp_s, x.blob_index, d)
                worst = max(worst, d)
                n += 1
    return n, worst


def _reference():
    """The frozen step (``tests/reference/localize_4d30179``) when run from a source checkout, else None."""
    tests = Path(__file__).resolve().parents[2] / "tests"
    if not (tests / "reference" / "localize_4d30179" / "localizer.py").is_file():
        return None
    if str(tests) not in sys.path:
        sys.path.insert(0, str(tests))
    return importlib.import_module("reference.localize_4d30179.localizer")


def _measure(n_blobs: int, rounds: int, frames_per_batch: int, detector: str = "pixels") -> dict:
    import cv2  # noqa: PLC0415

    from uvteam import localizer as now  # noqa: PLC0415

    before = _reference()
    cfg_now = now.LocalizerConfig()
    tracks, frames = scene(n_blobs, detector=detector)
    n_cmp, worst = 0, float("nan")
    if before is not None:
        cfg_before = before.LocalizerConfig()
        # the same step: the landmarks' noise as declared and no crowd fused with the pose, as the step was
        # then (both came later and move estimates and radii only); timed below as deployed, both on
        n_cmp, worst = same_results(before, now, tracks, frames, cfg_before,
                                    now.LocalizerConfig(learn_landmark_noise=False, fuse_pose=False),
                                    cycles=2 if n_blobs > 1000 else 3)
    # what the yardstick gets per frame: the landmarks (pixels and where the fixes put them), the blobs' points
    yard = []
    for f in frames:
        pos = now.ugv_positions(tracks, f.stamp_s, cfg_now)
        en = np.array([pos[u].en_m for u in f.landmarks.ugv])
        box = f.blobs.xyxy_px
        pts = np.vstack([f.blobs.xy_px, box[:, [0, 1]], box[:, [2, 1]], box[:, [2, 3]], box[:, [0, 3]]])
        yard.append((f.landmarks.xy_px.copy(), en, pts.reshape(-1, 1, 2)))
    states = {"now": now.LocalizerState()}
    steps = {"now": (now.localize_step, cfg_now)}
    order = ["now", "cv2"]
    if before is not None:
        states["before"] = before.LocalizerState()
        steps["before"] = (before.localize_step, cfg_before)
        order.insert(0, "before")
    per_step: dict[str, list[float]] = {k: [] for k in order}      # wall clock, us
    cpu_step: dict[str, list[float]] = {k: [] for k in order}      # this process's CPU time, us
    cycle = 0
    for r in range(rounds + 1):                       # round 0 warms up and is not counted
        tr, fr = shifted(tracks, frames, cycle)
        cycle += 1
        fr = fr[:frames_per_batch]
        for what in order[r % len(order):] + order[:r % len(order)]:      # who goes first rotates
            gc.collect()
            t0, c0 = time.perf_counter(), time.process_time()
            if what == "cv2":
                for lm_px, lm_en, pts in yard[:frames_per_batch]:
                    _cv2_step(cv2, lm_px, lm_en, pts)
            else:
                step, cfg = steps[what]
                st = states[what]
                for obs in fr:
                    st, _ = step(st, obs, tr, cfg)
                states[what] = st
            if r:
                per_step[what].append((time.perf_counter() - t0) / len(fr) * 1e6)
                cpu_step[what].append((time.process_time() - c0) / len(fr) * 1e6)
    nan = float("nan")
    med = {k: statistics.median(v) for k, v in per_step.items()}
    cpu = {k: statistics.median(v) for k, v in cpu_step.items()}
    speedup = statistics.median(b / n for b, n in zip(per_step["before"], per_step["now"])) if before else nan
    vs_cv2 = statistics.median(n / c for n, c in zip(per_step["now"], per_step["cv2"]))
    return {"blobs": n_blobs, "now_us": med["now"], "before_us": med.get("before", nan), "cv2_us": med["cv2"],
            "now_cpu_us": cpu["now"], "before_cpu_us": cpu.get("before", nan), "cv2_cpu_us": cpu["cv2"],
            "now_q10_us": float(np.quantile(per_step["now"], 0.1)), "now_q90_us": float(np.quantile(per_step["now"], 0.9)),
            "speedup": speedup, "now_over_cv2": vs_cv2, "crowds_compared": n_cmp, "max_diff_m": worst}


def bench_localize(rounds: int = 30, big_rounds: int = 5, blobs: tuple[int, ...] = (20, 10_000),
                   detector: str = "pixels") -> dict:
    """Time the step for 6 landmarks and each number of ``blobs``, on the noise the ``detector`` declares;
    print and return the figures."""
    try:
        import cv2  # noqa: PLC0415

        cv2.setNumThreads(1)
    except ImportError:
        pass
    try:
        cores = sorted(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = []
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    print(f"localize bench {datetime.datetime.now().isoformat(timespec='seconds')}: 6 landmarks, {detector} "
          f"detector's noise, cores {cores}, load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    out = {}
    for n in blobs:
        big = n > 1000
        r = _measure(n, big_rounds if big else rounds, 3 if big else int(FPS * CYCLE_S), detector)
        out[n] = r
        print(f"  {n:6d} blobs: now {r['now_us']:9.1f} us/step (10-90 %: {r['now_q10_us']:.1f}-{r['now_q90_us']:.1f}), "
              f"before {r['before_us']:9.1f} us, cv2 findHomography+perspectiveTransform {r['cv2_us']:8.1f} us")
        print(f"  {'':6s}        CPU time: now {r['now_cpu_us']:.1f} us, before {r['before_cpu_us']:.1f} us, "
              f"cv2 {r['cv2_cpu_us']:.1f} us")
        same = (f"same results on {r['crowds_compared']} crowds (largest difference {r['max_diff_m']:.1e} m)"
                if r["crowds_compared"] else "no 'before' (tests/reference is in a source checkout only)")
        print(f"  {'':6s}        before/now {r['speedup']:.2f}x, now/cv2 {r['now_over_cv2']:.2f}x; {same}")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m uvteam_ground.bench_localize", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=30, help="interleaved rounds of 30 frames (20 blobs)")
    ap.add_argument("--big-rounds", type=int, default=5, help="interleaved rounds of 3 frames (10,000 blobs)")
    ap.add_argument("--blobs", type=int, nargs="+", default=[20, 10_000], help="blob counts to time")
    ap.add_argument("--detector", choices=("pixels", "sensor"), default="pixels",
                    help="the noise the detections declare: the pixel pipeline's (deployed) or the sensor model's")
    args = ap.parse_args(argv)
    bench_localize(args.rounds, args.big_rounds, tuple(args.blobs), args.detector)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
