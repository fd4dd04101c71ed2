"""Does a crowd's velocity from corners on its walkers follow its blob when walkers go out of sight? A probe for
docs/results-worlds.md (session 50); not part of the product. Use it on tuning seeds or to trace a figure already
reported.

    .venv/bin/python docs/flow_velocity_probe.py scenarios/real-alt120-lm6.toml 1 10 14     # a crowd seen whole
    .venv/bin/python docs/flow_velocity_probe.py scenarios/real-alt120-lm6.toml 9 0.5 6     # the canopy spell
    .venv/bin/python docs/flow_velocity_probe.py scenarios/real-alt120-lm6.toml 1 5 35 blobs  # in the blobs' boxes

Runs one seed as `docs/blob_flow_probe.py` does (its frames and walkers' pixels). Every second frame, over the last
``LAG`` frames: the camera's motion (corners over the whole frame, pyramidal Lucas-Kanade, a RANSAC homography),
corners in the box round the walkers (10 px margin; with ``blobs``, in the box of the motion detector's crowd blob
that holds most of them, as the UAV service has it) followed the same way and checked backward to 0.5 px, and of
those that moved more than ``MOVED_PX`` against the ground, the median motion; beside it the walkers' own median
motion and that of their centroid (px over ``LAG`` frames; image y grows southwards).
"""

import sys

import cv2
import numpy as np
from blob_flow_probe import capture, moving_corners

LAG = 5
MOVED_PX = 2.0


def ground_motion(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The homography taking frame ``a``'s ground onto frame ``b``'s."""
    p0 = cv2.goodFeaturesToTrack(a, 800, 0.01, 8)
    p1, st, _ = cv2.calcOpticalFlowPyrLK(a, b, p0, None, winSize=(21, 21), maxLevel=3)
    ok = st.ravel() == 1
    H, _ = cv2.findHomography(p0[ok], p1[ok], cv2.RANSAC, 1.0)
    return H


def probe(rows, blobs: list | None = None) -> None:
    """``blobs``: per row, the detector's crowd blob boxes; corners are then sought in the box (10 px wider) of
    the blob holding most of the walkers, as the UAV service could, not round the walkers themselves."""
    pairs = []
    for j in range(LAG, len(rows), 2):
        (t, b, _), (_, a, walkers) = rows[j], rows[j - LAG]
        H = ground_motion(a, b)
        ma, mb = np.vstack(walkers).astype(np.float32), np.vstack(rows[j][2]).astype(np.float32)
        on_ground = cv2.perspectiveTransform(ma.reshape(-1, 1, 2), H).reshape(-1, 2)
        walkers_px = np.median(mb - on_ground, 0)
        centroid_px = mb.mean(0) - on_ground.mean(0)
        lo, hi = ma.min(0), ma.max(0)
        if blobs is not None:
            boxes = blobs[j - LAG]
            held = [int(((ma >= bx[:2]) & (ma <= bx[2:])).all(1).sum()) for bx in boxes]
            if not held or max(held) == 0:
                continue
            lo, hi = boxes[int(np.argmax(held))].reshape(2, 2)
        x0, y0 = np.maximum(np.floor(lo - 10), 0).astype(int)
        x1, y1 = np.ceil(hi + 10).astype(int)
        _, moved = moving_corners(a, b, H, (x0, y0, x1, y1), back_px=0.5)
        keep = np.hypot(*moved.T) > MOVED_PX
        corners_px = np.median(moved[keep], 0) if keep.any() else np.full(2, np.nan)
        print(f"t {t:4.1f} s: walkers' median {walkers_px.round(1)}, their centroid {centroid_px.round(1)}, "
              f"{keep.sum():3d} corners moved, their median {corners_px.round(1)} px over {LAG} frames")
        if keep.any():
            pairs.append((walkers_px, corners_px))
    if pairs:
        w, c = (np.array(x) for x in zip(*pairs))
        d = c - w
        off = np.hypot(*d.T)
        print(f"{len(pairs)} windows with corners: speed ratio (corners / walkers) median "
              f"{np.median(np.hypot(*c.T) / np.hypot(*w.T)):.2f}, difference median {np.median(d, 0).round(2)} px, "
              f"median absolute {np.median(np.abs(d), 0).round(2)} px, RMS {np.sqrt((d ** 2).mean(0)).round(2)} px, "
              f"over 2 px off in {np.mean(off > 2.0):.2f} of windows")


if __name__ == "__main__":
    if len(sys.argv) not in (5, 6) or sys.argv[5:] not in ([], ["blobs"]):
        raise SystemExit(__doc__)
    found = [] if sys.argv[5:] else None
    rows = capture(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]), found)
    probe(rows, found)
