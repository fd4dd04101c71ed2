"""Can the motion inside one blob tell two crowds apart? A probe for docs/results-worlds.md (session 38); not part of
the product. Use it on tuning seeds.

    .venv/bin/python docs/blob_flow_probe.py scenarios/real-alt60-lm6-two.toml 16 28 33   # one blob, two crowds
    .venv/bin/python docs/blob_flow_probe.py scenarios/real-alt60-lm6.toml 1 10 15        # one crowd

Runs one seed through the experiment (rendered frames, the deployed node classes) and keeps the full-resolution
grey frames between two times with every walker's pixel position. Then, every 0.5 s, over the last 0.5 s: the
camera's motion (corners over the whole frame, pyramidal Lucas-Kanade, a RANSAC homography), corners round the
walkers tracked the same way, those that moved more than 2 px against the ground split in two by 2-means on
their position, and per half the median of that motion. Prints how well the halves agree with which crowd the
nearest walker belongs to (with two crowds) and how far apart the halves' median motions are, in pixels.
"""

import sys

import cv2
import numpy as np

import uvteam.vision.motion as motion
from uvteam.camera import project
from uvteam.io.files import load_scenario
from uvteam_sim.experiment import SimTeam
from uvteam_sim.world import PERSON_CENTRE_HEIGHT_M

LAG_FRAMES = 5
MOVED_PX = 2.0


def capture(path: str, seed: int, t0_s: float, t1_s: float, blobs: list | None = None):
    """(times s, grey frames, per frame a list of each crowd's walkers in pixels) between t0_s and t1_s; with
    ``blobs``, the boxes (x0, y0, x1, y1) of the motion detector's crowd blobs in each of those frames appended
    to it."""
    team = SimTeam(load_scenario(path), seed, "pixels")
    world = team.sim.world
    first, pose, rows = [], {}, []
    update, render = motion.MotionDetector.update, team.renderer.render

    def on_render(p):
        pose["p"] = p
        return render(p)

    def on_update(det, img, stamp_s, *a, **k):
        first[:] = first or [stamp_s]
        if t0_s <= stamp_s - first[0] <= t1_s:
            walkers = []
            for i in range(len(world.sc.crowds)):
                m = world.members(i)
                walkers.append(project(world.camera, pose["p"],
                                       np.column_stack([m, world.terrain_up_m(m) + PERSON_CENTRE_HEIGHT_M])))
            grey = img if img.ndim == 2 else cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
            rows.append((stamp_s - first[0], grey.copy(), walkers))
            res = update(det, img, stamp_s, *a, **k)
            if blobs is not None:
                blobs.append(res.blobs.xyxy_px[res.carved < 0])
            return res
        return update(det, img, stamp_s, *a, **k)

    team.renderer.render = on_render
    motion.MotionDetector.update = on_update
    try:
        team.run(t1_s + 0.2)
    finally:
        motion.MotionDetector.update = update
    return rows


def moving_corners(a: np.ndarray, b: np.ndarray, H: np.ndarray, box: tuple[int, int, int, int],
                   back_px: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Corners of frame ``a`` inside ``box`` (x0, y0, x1, y1) followed into ``b`` (pyramidal Lucas-Kanade; with
    ``back_px``, kept only where the backward track returns within it): their positions in ``a`` and their motion
    against the ground (``H``: ``a``'s ground onto ``b``'s), in pixels."""
    x0, y0, x1, y1 = box
    mask = np.zeros_like(a)
    mask[y0:y1, x0:x1] = 255
    q0 = cv2.goodFeaturesToTrack(a, 400, 0.005, 3, mask=mask)
    q1, st, _ = cv2.calcOpticalFlowPyrLK(a, b, q0, None, winSize=(9, 9), maxLevel=2)
    ok = st.ravel() == 1
    if back_px is not None:
        qb, _, _ = cv2.calcOpticalFlowPyrLK(b, a, q1, None, winSize=(9, 9), maxLevel=2)
        ok &= np.hypot(*(qb - q0).reshape(-1, 2).T) < back_px
    q0, q1 = q0[ok].reshape(-1, 2), q1[ok].reshape(-1, 2)
    return q0, q1 - cv2.perspectiveTransform(q0.reshape(-1, 1, 2), H).reshape(-1, 2)


def probe(rows) -> None:
    for j in range(LAG_FRAMES, len(rows), 5):
        (t, b, _), (_, a, walkers) = rows[j], rows[j - LAG_FRAMES]
        p0 = cv2.goodFeaturesToTrack(a, 800, 0.01, 8)
        p1, st, _ = cv2.calcOpticalFlowPyrLK(a, b, p0, None, winSize=(21, 21), maxLevel=3)
        ok = st.ravel() == 1
        H, _ = cv2.findHomography(p0[ok], p1[ok], cv2.RANSAC, 1.0)
        mem = np.vstack(walkers)
        who = np.concatenate([np.full(len(w), k) for k, w in enumerate(walkers)])
        x0, y0 = np.maximum(np.floor(mem.min(0) - 15), 0).astype(int)
        x1, y1 = np.ceil(mem.max(0) + 15).astype(int)
        q0, moved = moving_corners(a, b, H, (x0, y0, x1, y1))
        keep = np.hypot(*moved.T) > MOVED_PX
        q, r = q0[keep], moved[keep]
        _, half, _ = cv2.kmeans(q.astype(np.float32), 2, None,
                                (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 0.1), 5, cv2.KMEANS_PP_CENTERS)
        half = half.ravel()
        d = np.sqrt(((q[:, None] - mem[None]) ** 2).sum(-1))
        near, nearest = d.min(1) < 6.0, who[d.argmin(1)]
        agree = (max(np.mean(half[near] == nearest[near]), np.mean(half[near] != nearest[near]))
                 if len(walkers) > 1 and near.any() else float("nan"))
        dv = np.hypot(*(np.median(r[half == 0], 0) - np.median(r[half == 1], 0)))
        print(f"t {t:5.1f} s: {keep.sum():3d} corners moved ({near.sum()} on walkers), halves agree with the crowds "
              f"{agree:.2f}, their motions {dv:.1f} px apart over {LAG_FRAMES} frames")


if __name__ == "__main__":
    if len(sys.argv) != 5:
        raise SystemExit(__doc__)
    probe(capture(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])))
