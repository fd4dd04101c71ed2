"""Ways to place a crowd's blob, each against the crowd's true centre in the image (a diagnostic for
docs/results-worlds.md, session 31; not part of the product).

    .venv/bin/python docs/centre_estimators.py run OUT.pkl SCENARIO.toml SEED...
    .venv/bin/python docs/centre_estimators.py summary OUT.pkl...

``run`` runs each seed as ``uvteam experiment --detector pixels`` does (:class:`SimTeam`) and, for every
crowd blob the motion detector measures whole (one blob of its component, no vehicle in it), places it
from the same pixels in several ways; per frame and true crowd, the blobs nearest that crowd (within
12 m) are joined by their weights, as :mod:`uvteam.crowds` joins a crowd's parts by area, and the
distance to the crowd's members' mean in the image is kept, in ground metres at the scenario's
altitude. Open loop in what it measures: the detector's placement before the localizer, the grouping's
tracks, the strays' pull (:mod:`uvteam.vision.motion` step 7) and the transform. ``summary`` prints
mean, median, p95, p99 and max per way:

- ``E0``: the shipped one (:func:`uvteam.vision.motion._centre_now`): every moving pixel alike, each
  coordinate a straight line in the pixels' age taken at age 0; weight: the pixel count;
- ``D1``: each moving pixel widened to a disc of a walker's radius (0.5 m), each of the union's pixels as
  old as the youngest moving pixel in its disc, placed as ``E0``; weight: the union's pixel count;
- ``Z1``: ``E0`` moved by as much as that union moves the pixels' centroid; weight: the pixel count;
- ``IT``: each moving pixel weighed by one over the moving pixels in the square of a walker's radius
  round it, the line in age fitted so weighted; weight: the sum of the weights.
"""

import pickle
import sys

import cv2
import numpy as np

import uvteam.vision.motion as motion
from uvteam.io.files import load_scenario
from uvteam_sim.experiment import SimTeam

NEAR_M = 12.0
WALKER_RADIUS_M = 0.5


def _placed(m8: np.ndarray, age: np.ndarray, w: np.ndarray | None = None) -> tuple[float, float]:
    """``E0``'s line in age taken at age 0, each pixel weighed by ``w`` (None: alike)."""
    if w is None:
        return motion._centre_now(m8, age, cv2.boundingRect(m8))
    a = age.astype(np.float32)
    m0, m1, m2 = cv2.moments(w), cv2.moments(w * a), cv2.moments(w * a * a)
    n = m0["m00"]
    x, y = m0["m10"] / n, m0["m01"] / n
    a_mean = m1["m00"] / n
    a_var = m2["m00"] / n - a_mean * a_mean
    if a_var > 1e-6:
        x -= (m1["m10"] / n - a_mean * x) / a_var * a_mean
        y -= (m1["m01"] / n - a_mean * y) / a_var * a_mean
    return x, y


def placements(m8: np.ndarray, age: np.ndarray, r: int) -> dict[str, tuple[tuple[float, float], float]]:
    """Each way's (x, y) in the crop's pixels and its weight, for a blob's moving pixels ``m8`` (uint8 0/1)
    with the history's ``age`` (same crop), ``r`` a walker's radius in processed pixels."""
    area = float(np.count_nonzero(m8))
    out = {"E0": (_placed(m8, age), area)}
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    pad = r + 1
    mp = np.pad(m8, pad)
    union = cv2.dilate(mp, k)
    young = cv2.erode(np.pad(np.where(m8 > 0, age, 255).astype(np.uint8), pad, constant_values=255), k)
    x, y = _placed(union, young)
    out["D1"] = ((x - pad, y - pad), float(np.count_nonzero(union)))
    mu, mo = cv2.moments(union, True), cv2.moments(mp, True)
    e0 = out["E0"][0]
    out["Z1"] = ((e0[0] + mu["m10"] / mu["m00"] - mo["m10"] / mo["m00"],
                  e0[1] + mu["m01"] / mu["m00"] - mo["m01"] / mo["m00"]), area)
    f = m8.astype(np.float32)
    around = cv2.boxFilter(f, -1, (2 * r + 1, 2 * r + 1), normalize=False, borderType=cv2.BORDER_CONSTANT)
    w = np.divide(f, around, out=np.zeros_like(f), where=f > 0)
    out["IT"] = (_placed(m8, age, w), float(w.sum()))
    return out


def run(out_path: str, path: str, seeds: list[int]) -> None:
    sc = load_scenario(path)
    rows = []
    for seed in seeds:
        team = SimTeam(sc, seed, "pixels")
        world = team.sim.world
        px_per_m = world.camera.focal_px / sc.uav.altitude_agl_m
        now: dict = {"blobs": []}
        render, update, measure = team.renderer.render, motion.MotionDetector.update, motion.MotionDetector._measure

        def on_render(pose):        # the pose the frame was drawn with
            now["pose"] = pose
            return render(pose)

        def on_update(det, img, stamp_s, *args, **kwargs):
            now["blobs"] = []
            result = update(det, img, stamp_s, *args, **kwargs)
            truth = [g.mean(0) for g in world.crowd_groups_px(now["pose"])] if now["blobs"] else []
            for k, centre in enumerate(truth):
                near = []
                for ways in now["blobs"]:
                    d = [np.hypot(*(np.array(ways["E0"][0]) - c)) for c in truth]
                    if int(np.argmin(d)) == k and d[k] / px_per_m <= NEAR_M:
                        near.append(ways)
                if near:
                    errors = {}
                    for way in near[0]:
                        xy = np.array([b[way][0] for b in near])
                        w = np.array([b[way][1] for b in near])
                        errors[way] = float(np.hypot(*((xy * w[:, None]).sum(0) / w.sum() - centre))) / px_per_m
                    rows.append((seed, stamp_s, errors, len(near)))
            return result

        def on_measure(det, comp, recent, age, x, y, carve, tails, r2):
            out = measure(det, comp, recent, age, x, y, carve, tails, r2)
            if len(out) == 1 and out[0][3] < 0:
                s = det.cfg.process_scale
                r = max(1, int(round(WALKER_RADIUS_M * px_per_m * s)))
                m8 = np.ascontiguousarray(comp & (recent > 0)).view(np.uint8)
                now["blobs"].append({k: (((v[0][0] + x + 0.5) / s - 0.5, (v[0][1] + y + 0.5) / s - 0.5), v[1])
                                     for k, v in placements(m8, age, r).items()})
            return out

        team.renderer.render = on_render
        motion.MotionDetector.update, motion.MotionDetector._measure = on_update, on_measure
        try:
            team.run()
        finally:
            motion.MotionDetector.update, motion.MotionDetector._measure = update, measure
        print(f"{sc.name} seed {seed}: {len(rows)} crowd frames so far", flush=True)
    with open(out_path, "wb") as f:
        pickle.dump(rows, f)


def summary(paths: list[str]) -> None:
    rows = [r for p in paths for r in pickle.load(open(p, "rb"))]
    print(f"{len(rows)} crowd frames")
    for way in sorted({k for _, _, e, _ in rows for k in e}):
        e = np.array([d[way] for _, _, d, _ in rows])
        print(f"{way}: mean {e.mean():.3f} median {np.median(e):.3f} p95 {np.percentile(e, 95):.3f} "
              f"p99 {np.percentile(e, 99):.3f} max {e.max():.2f} m")


if __name__ == "__main__":
    if len(sys.argv) >= 4 and sys.argv[1] == "run":
        run(sys.argv[2], sys.argv[3], [int(s) for s in sys.argv[4:]])
    elif len(sys.argv) >= 3 and sys.argv[1] == "summary":
        summary(sys.argv[2:])
    else:
        raise SystemExit(__doc__)
