"""How often step 3's tests mark still ground as moving: real aerial frames (AU-AIR, read from
../shared/data, never copied) drifting by sub-pixel steps, with sensor noise and a registration error of
the given size, and no walker at all (a diagnostic for docs/results-worlds.md, session 34; not part of
the product).

    .venv/bin/python docs/lagged_noise.py 0.1

For each of six frames (scaled to 960 x 540 and taken as the processed frame) five frames are made: the
camera drifting 0.37 px right and 0.23 px up a frame, jittered by 0.1 px, with Gaussian noise of 1.5 grey
levels; each earlier frame is warped onto the last by its true shift plus an error drawn with sigma
REG_ERR_PX per axis (what a registration misses). Prints, per frame and on average, the share of pixels
(parts per million) marked by the two-frame test as shipped (per-pixel and box tests), by one of the
lagged test's comparisons (the frame 0.2 s back at 10 frames a second), and by the lagged test (both
comparisons, 0.2 and 0.4 s back) with its own floor and noise factor and with the two-frame test's; raw
and after step 3's clean-up (``speckle``).
"""

import sys
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

from uvteam.vision.motion import MotionDetector, _local_range
from uvteam.vision.uav import UavVisionConfig

AUAIR = Path(__file__).resolve().parents[2] / "shared" / "data" / "uav_auair_subset" / "images"
SIZE = (960, 540)


def frames_of(path: Path, rng: np.random.Generator) -> list[tuple[np.ndarray, tuple[float, float]]]:
    g = cv2.resize(cv2.cvtColor(cv2.imread(str(path)), cv2.COLOR_BGR2GRAY).astype(np.float32), SIZE,
                   interpolation=cv2.INTER_AREA)
    out = []
    for k in range(5):
        dx, dy = 0.37 * k + rng.normal(0, 0.1), -0.23 * k + rng.normal(0, 0.1)
        img = cv2.warpAffine(g, np.float32([[1, 0, dx], [0, 1, dy]]), SIZE, flags=cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_REFLECT)
        out.append((np.clip(img + rng.normal(0, 1.5, img.shape), 0, 255).astype(np.uint8), (dx, dy)))
    return out


def main(reg_err_px: float) -> None:
    shipped = replace(UavVisionConfig(focal_px=790.0, colors=("red",)).motion, process_scale=1.0)
    as_two_frame = replace(shipped, lag_diff_floor=shipped.diff_floor, lag_noise_k=shipped.noise_k)
    dets = {"own": MotionDetector(shipped), "two-frame's": MotionDetector(as_two_frame)}
    rng = np.random.default_rng(1)
    rows: dict[str, list[float]] = {}
    paths = sorted(AUAIR.glob("*.jpg"))[:6]
    if not paths:
        raise SystemExit(f"no AU-AIR frames in {AUAIR} (../shared/data/uav_auair_subset, see its SOURCES.md)")
    for path in paths:
        frames = frames_of(path, rng)
        err = rng.normal(0, reg_err_px, (5, 2))
        curr, (cx, cy) = frames[4]
        valid = np.zeros(curr.shape, np.uint8)
        valid[20:-20, 20:-20] = 255
        n = int((valid > 0).sum())

        def onto_curr(j: int) -> np.ndarray:
            old, (ox, oy) = frames[j]
            A = np.float32([[1, 0, cx - ox + err[j, 0]], [0, 1, cy - oy + err[j, 1]]])
            return cv2.warpAffine(old, A, SIZE, flags=cv2.INTER_LINEAR)

        curr_range = _local_range(curr)
        masks = {"two-frame test": dets["own"]._changed(curr, curr_range, onto_curr(3), valid)}
        for name, det in dets.items():
            a = det._changed(curr, curr_range, onto_curr(2), valid, lagged=True)
            b = det._changed(curr, curr_range, onto_curr(0), valid, lagged=True)
            if name == "own":
                masks["one lagged comparison, own floor"] = a
            masks[f"lagged test, {name} floor"] = cv2.bitwise_and(a, b)
        for name in list(masks):
            masks[name + ", cleaned"] = dets["own"]._cleaned(masks[name].copy())
        for name, m in masks.items():
            rows.setdefault(name, []).append(1e6 * np.count_nonzero(m) / n)
    print(f"registration error {reg_err_px} px per axis; ppm of still ground marked, per frame and mean")
    for name, v in rows.items():
        print(f"{name:46s} " + " ".join(f"{x:6.0f}" for x in v) + f"   mean {np.mean(v):6.0f}")


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 0.1)
