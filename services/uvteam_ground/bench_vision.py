"""Vision speed on one core (cv2.setNumThreads(1), pinned by `uvteam bench`), each figure beside its yardstick.

The project's motion detector (:class:`uvteam.vision.motion.MotionDetector`, configured as the UAV
pipeline configures it: :class:`uvteam.vision.uav.UavVision`) runs interleaved with two references on
the same frames in the same process: the frames alternate between them (A B, then B A, ...), so the
machine's drift (other processes, clocks, caches) hits all of them alike and their ratio means
something on a shared machine where the absolute fps do not. Three passes over the frames, each
frame's least time kept, so a pass another process interrupted does not count against either.

- **plain**: the paper's pipeline done plainly at the same processing scale (:class:`PlainPipeline`):
  goodFeaturesToTrack, pyramidal Lucas-Kanade, a RANSAC partial affine fit, warp, absdiff, threshold,
  open and close, connected components. Kept here, not in the product.
- **warp floor**: warping the processed (grey, scaled) frame once, the least any such pipeline does.

Frame sets: karma.mp4 (../shared/data/uav_oblique_gopro_karma, a real oblique flight) at 1280x720 and
1920x1080; the AU-AIR flow pairs (../shared/data/uav_auair_subset, real 1920x1080 frames, non-commercial:
read from there, never copied; skipped with a message when absent), played back and forth; and the
project's rendered frames of the paper scenarios (from the simulator, through the ``uvteam.bench_frames``
entry points). The HOG people detector is timed on vtest.avi at 640x480.
"""

from __future__ import annotations

import datetime
import json
import time
from importlib.metadata import entry_points
from pathlib import Path

import cv2
import numpy as np

from uvteam.camera import PinholeCamera
from uvteam.vision.motion import MotionConfig, MotionDetector
from uvteam.vision.people import HogConfig, PeopleDetector
from uvteam.vision.uav import UavVision, UavVisionConfig

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
KARMA = DATA / "uav_oblique_gopro_karma" / "karma.mp4"
AUAIR = DATA / "uav_auair_subset"
AUAIR_PAIRS = (("frame_20190905111947_x_0000868.jpg", "frame_20190905111947_x_0000869.jpg"),
               ("frame_20190905103112_x_0004381.jpg", "frame_20190905103112_x_0004387.jpg"),
               ("frame_20190905142119_x_0002559.jpg", "frame_20190905142119_x_0002570.jpg"))
HFOV_DEG = 78.0          # the project's camera; karma and the Bebop 2 are close to it
KARMA_ALT_M = 50.0       # karma.mp4 has no telemetry: sized as a UAV at 50 m would be
SIZES = ((1280, 720), (1920, 1080))


class PlainPipeline:
    """The paper's moving-camera pipeline, plainly, at ``cfg.process_scale``, with the project's corner,
    flow, threshold and kernel settings (``cfg``): the yardstick for :class:`MotionDetector`."""

    def __init__(self, cfg: MotionConfig) -> None:
        self.cfg = cfg
        self.prev: np.ndarray | None = None
        self.k_open = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (cfg.open_px, cfg.open_px))
        self.k_close = cv2.getStructuringElement(cv2.MORPH_RECT, (cfg.merge_px, cfg.merge_px))
        self.lk = dict(winSize=(cfg.lk_window_px, cfg.lk_window_px), maxLevel=cfg.lk_levels,
                       criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 20, 0.03))

    def update(self, frame: np.ndarray) -> int:
        cfg, s = self.cfg, self.cfg.process_scale
        gray = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        curr = cv2.resize(gray, None, fx=s, fy=s, interpolation=cv2.INTER_AREA) if s != 1.0 else gray
        prev, self.prev = self.prev, curr
        if prev is None:
            return 0
        p0 = cv2.goodFeaturesToTrack(prev, cfg.max_corners, cfg.corner_quality, cfg.corner_min_distance_px, blockSize=5)
        if p0 is None or len(p0) < 8:
            return 0
        p1, st, _ = cv2.calcOpticalFlowPyrLK(prev, curr, p0, None, **self.lk)
        ok = st.ravel() == 1
        if ok.sum() < 8:
            return 0
        A, _ = cv2.estimateAffinePartial2D(p0[ok], p1[ok], method=cv2.RANSAC, ransacReprojThreshold=cfg.ransac_px)
        if A is None:
            return 0
        h, w = curr.shape
        warped = cv2.warpAffine(prev, A, (w, h))
        _, moving = cv2.threshold(cv2.absdiff(curr, warped), cfg.diff_threshold, 255, cv2.THRESH_BINARY)
        moving = cv2.morphologyEx(moving, cv2.MORPH_OPEN, self.k_open)
        moving = cv2.morphologyEx(moving, cv2.MORPH_CLOSE, self.k_close)
        n, _, stats, _ = cv2.connectedComponentsWithStats(moving, connectivity=8)
        area = stats[1:, cv2.CC_STAT_AREA] / (s * s)
        return int(((area >= cfg.min_area_px) & (area <= cfg.max_area_px)).sum())


def uav_motion_config(width_px: int, height_px: int, alt_agl_m: float, hfov_deg: float = HFOV_DEG,
                      frame: np.ndarray | None = None) -> MotionConfig:
    """The motion detector's configuration the UAV pipeline builds for this camera at this height."""
    vis = UavVision(UavVisionConfig(focal_px=PinholeCamera(width_px, height_px, hfov_deg).focal_px, colors=("red",)))
    vis.update(frame if frame is not None else np.zeros((height_px, width_px, 3), np.uint8), 1.0, alt_agl_m)
    return vis.motion_config


def compare(frames: list[np.ndarray], cfg: MotionConfig, dt_s: float, passes: int = 3) -> dict:
    """Project, plain and warp floor over the same frames, interleaved frame by frame (the order
    alternating), ``passes`` times over the list from a fresh start. Each frame's time is its least over
    the passes, on two clocks: the wall clock, and this thread's CPU time (OpenCV runs on this one
    thread), which other processes on the core do not add to. fps = frames / the sum of those times."""
    s = cfg.process_scale
    small = [cv2.resize(cv2.cvtColor(f, cv2.COLOR_BGR2GRAY), None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
             if s != 1.0 else cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in frames]
    h, w = small[0].shape
    A = np.float32([[np.cos(0.01), -np.sin(0.01), 3.2], [np.sin(0.01), np.cos(0.01), -1.7]])
    n = len(frames) - 1
    who_all = ("project", "plain", "warp")
    wall = {k: np.full(n, np.inf) for k in who_all}
    cpu = {k: np.full(n, np.inf) for k in who_all}
    for p in range(passes):
        det, plain = MotionDetector(cfg), PlainPipeline(cfg)
        det.update(frames[0], 0.0)
        plain.update(frames[0])
        for i in range(1, len(frames)):
            for who in (who_all if (i + p) % 2 == 0 else who_all[::-1]):
                t0, c0 = time.perf_counter(), time.thread_time()
                if who == "project":
                    det.update(frames[i], i * dt_s)
                elif who == "plain":
                    plain.update(frames[i])
                else:
                    cv2.warpAffine(small[i], A, (w, h))
                c1, t1 = time.thread_time(), time.perf_counter()
                wall[who][i - 1] = min(wall[who][i - 1], t1 - t0)
                cpu[who][i - 1] = min(cpu[who][i - 1], c1 - c0)
    fps = {k: n / v.sum() for k, v in wall.items()}
    cfps = {k: n / v.sum() for k, v in cpu.items()}
    return {"fps_project": fps["project"], "fps_plain": fps["plain"], "fps_warp": fps["warp"],
            "ratio_project_plain": fps["project"] / fps["plain"],
            "cpu_fps_project": cfps["project"], "cpu_fps_plain": cfps["plain"], "cpu_fps_warp": cfps["warp"],
            "cpu_ratio_project_plain": cfps["project"] / cfps["plain"],
            "frames": n, "passes": passes, "process_scale": s}


def _video(path: Path, n: int, size: tuple[int, int]) -> list[np.ndarray]:
    cap = cv2.VideoCapture(str(path))
    out = []
    while len(out) < n:
        ok, f = cap.read()
        if not ok:
            break
        out.append(cv2.resize(f, size, interpolation=cv2.INTER_AREA) if f.shape[1::-1] != size else f)
    cap.release()
    return out


def auair_pairs(size: tuple[int, int], repeats: int = 10) -> tuple[list[np.ndarray], float] | None:
    """The AU-AIR flow pairs at ``size``, each played back and forth ``repeats`` times, and their mean
    altitude (m); None when the data is not beside the checkout."""
    if not (AUAIR / "images").is_dir():
        return None
    alt = {}
    try:
        for a in json.loads((AUAIR / "annotations.json").read_text())["annotations"]:
            alt[a["image_name"]] = a["altitude"] / 1000.0
    except (OSError, ValueError, KeyError):
        pass
    frames, alts = [], []
    for pa, pb in AUAIR_PAIRS:
        imgs = [cv2.imread(str(AUAIR / "images" / x)) for x in (pa, pb)]
        if any(i is None for i in imgs):
            return None
        imgs = [cv2.resize(i, size, interpolation=cv2.INTER_AREA) if i.shape[1::-1] != size else i for i in imgs]
        frames += imgs * repeats
        alts += [alt.get(pa, 25.0), alt.get(pb, 25.0)]
    return frames, float(np.mean(alts))


def frame_sets(n: int = 90) -> list[tuple[str, list[np.ndarray], float, float]]:
    """(name, frames, height above ground m, frame interval s) for every set that is here."""
    sets = []
    if KARMA.is_file():
        for size in SIZES:
            sets.append((f"karma.mp4 {size[0]}x{size[1]}", _video(KARMA, n, size), KARMA_ALT_M, 1 / 29.97))
    else:
        print(f"vision: {KARMA} not found: karma.mp4 skipped")
    for size in SIZES:
        got = auair_pairs(size)
        if got is None:
            print(f"vision: {AUAIR / 'images'} not found: the AU-AIR real-imagery pairs skipped")
            break
        sets.append((f"AU-AIR pairs {size[0]}x{size[1]}", got[0], got[1], 0.1))
    for ep in sorted(entry_points(group="uvteam.bench_frames"), key=lambda e: e.name):
        for name, frames, alt_m, dt_s in ep.load()(n=min(n, 60)):
            sets.append((name, frames, alt_m, dt_s))
    return sets


def bench_motion(n: int = 90) -> dict:
    today = datetime.date.today().isoformat()
    res = {}
    print(f"UAV motion detector vs the plain paper pipeline, interleaved on one core ({today}, OpenCV "
          f"{cv2.__version__}):")
    print(f"  {'':<36} {'------- CPU time -------':>33}   {'------ wall clock ------':>33}")
    print(f"  {'frames':<30} {'scale':>5} {'project':>9} {'plain':>9} {'ratio':>6} {'warp':>6}   "
          f"{'project':>9} {'plain':>9} {'ratio':>6} {'warp':>6}")
    for name, frames, alt_m, dt_s in frame_sets(n):
        h, w = frames[0].shape[:2]
        cfg = uav_motion_config(w, h, alt_m, frame=frames[0])
        r = compare(frames, cfg, dt_s)
        res[name] = r
        print(f"  {name:<30} {r['process_scale']:>5.2f} {r['cpu_fps_project']:>5.1f} fps {r['cpu_fps_plain']:>5.1f} fps "
              f"{r['cpu_ratio_project_plain']:>5.2f}x {r['cpu_fps_warp']:>6.0f}   {r['fps_project']:>5.1f} fps "
              f"{r['fps_plain']:>5.1f} fps {r['ratio_project_plain']:>5.2f}x {r['fps_warp']:>6.0f}", flush=True)
    print("  ratio = project fps / plain fps (target >= 1.5 on karma.mp4 and AU-AIR at both sizes); fps from each\n"
          "  frame's least time over 3 interleaved passes; CPU time is this thread's (what the detector costs),\n"
          "  the wall clock adds whatever else ran on the core")
    return res


def bench_hog() -> dict:
    res = {}
    fr = _video(DATA / "pedestrians_static_opencv" / "vtest.avi", 20, (640, 480))
    if not fr:
        print("vision: vtest.avi not found: HOG skipped")
        return res
    for name, cfg in (("tuned", HogConfig()), ("OpenCV default", HogConfig(upscale=1.0, scale_step=1.05, hit_threshold=0.0))):
        d = PeopleDetector(cfg)
        t0 = time.perf_counter()
        for f in fr:
            d.detect(f)
        fps = len(fr) / (time.perf_counter() - t0)
        res[f"hog_fps_{name}"] = fps
        print(f"HOG people detector 640x480, {name}: {fps:.1f} fps on one core (target >= 10)")
    return res


def run() -> dict:
    cv2.setNumThreads(1)
    if not DATA.is_dir():
        print(f"vision: {DATA} not found (the benchmark uses the real clips in ../shared/data)")
        return {}
    return {"motion": bench_motion(), **bench_hog()}
