"""Can corners tracked on the walkers over a second tell which crowd each walker is in, and so whether two crowds
mingle by the scenarios' rule (walkers of the two within 2 m: one crowd)? A probe for docs/results-worlds.md
(session 41); not part of the product. Use it on tuning seeds.

    .venv/bin/python docs/walker_track_probe.py scenarios/real-alt60-lm6-two.toml 16 10 40
    .venv/bin/python docs/walker_track_probe.py ../shared/scenarios/field-alt100-lm6.toml 3 15 50

Runs one seed as `docs/blob_flow_probe.py` does (its frames and walkers' pixels), then follows corners round the
walkers frame to frame (pyramidal Lucas-Kanade, kept while the backward track returns within 0.5 px; new corners
every 5 frames) in the first frame's pixels (the camera's motion taken out by a RANSAC homography per frame pair).
A corner followed for ``LAG`` frames that moved more than ``MOVED_PX_S`` against the ground is a moving corner;
one within 6 px of a walker is on that walker. Per frame with both crowds' walkers in view it prints:

- how often a corner on a walker is given the right crowd by the nearer of the two crowds' velocities (the
  median of their own corners': the crowds' walks known exactly, as the team's tracks know them at best);
- the least distance between corners of the two crowds, in ground metres (the scenario's altitude and camera),
  the moving corners split three ways: by 2-means on their velocities (what a detector without the crowds' walks
  could do), by the nearer crowd velocity as above (every moving corner, on a walker or not), and, of the corners
  on walkers, by the walker each is on (every one given its right crowd), against the scoring's rule on every
  walker, at thresholds of 1 to 3 m.
"""

import math
import sys

import cv2
import numpy as np
from blob_flow_probe import capture

from uvteam.io.files import load_scenario

LAG = 10             # frames a corner is followed before its velocity counts
MOVED_PX_S = 5.0     # a corner moving faster than this against the ground is on something that moves
ON_WALKER_PX = 6.0


def follow(rows):
    """Per frame: (t, corners as rows of [vx, vy px/s, x, y px], the walker each is on or -1, walkers px, crowd
    of each walker)."""
    H_first, prev, tracks, out = np.eye(3), None, [], []
    for j, (t, g, walkers) in enumerate(rows):
        if prev is not None:
            p0 = cv2.goodFeaturesToTrack(prev, 800, 0.01, 8)
            p1, st, _ = cv2.calcOpticalFlowPyrLK(prev, g, p0, None, winSize=(21, 21), maxLevel=3)
            ok = st.ravel() == 1
            H, _ = cv2.findHomography(p1[ok], p0[ok], cv2.RANSAC, 1.0)
            H_first = H_first @ H
            live = [tr for tr in tracks if tr["alive"]]
            if live:
                q0 = np.array([tr["px"] for tr in live], np.float32).reshape(-1, 1, 2)
                q1, s1, _ = cv2.calcOpticalFlowPyrLK(prev, g, q0, None, winSize=(9, 9), maxLevel=2)
                qb, s2, _ = cv2.calcOpticalFlowPyrLK(g, prev, q1, None, winSize=(9, 9), maxLevel=2)
                back = np.hypot(*(qb - q0).reshape(-1, 2).T)
                first = cv2.perspectiveTransform(q1.astype(float), H_first).reshape(-1, 2)
                for tr, px, f, a, b, e in zip(live, q1.reshape(-1, 2), first, s1.ravel(), s2.ravel(), back):
                    tr["alive"] = bool(a and b and e < 0.5)
                    if tr["alive"]:
                        tr["px"], tr["first"] = px, tr["first"] + [f]
        mem = np.vstack(walkers)
        who = np.concatenate([np.full(len(w), k) for k, w in enumerate(walkers)])
        if j % 5 == 0:
            x0, y0 = np.maximum(np.floor(mem.min(0) - 20), 0).astype(int)
            x1, y1 = np.ceil(mem.max(0) + 20).astype(int)
            mask = np.zeros_like(g)
            mask[y0:y1, x0:x1] = 255
            for tr in tracks:
                if tr["alive"]:
                    cv2.circle(mask, tuple(int(v) for v in tr["px"]), 3, 0, -1)
            q = cv2.goodFeaturesToTrack(g, 600, 0.003, 3, mask=mask)
            for px in ([] if q is None else q.reshape(-1, 2)):
                f = cv2.perspectiveTransform(px.reshape(1, 1, 2).astype(float), H_first).ravel()
                tracks.append({"px": px, "first": [f], "alive": True})
        tracks = [tr for tr in tracks if tr["alive"]]
        rows_j, on = [], []
        for tr in tracks:
            if len(tr["first"]) > LAG:
                v = (tr["first"][-1] - tr["first"][-1 - LAG]) / LAG * 10.0
                d = np.hypot(*(mem - tr["px"]).T)
                rows_j.append([*v, *tr["px"]])
                on.append(int(who[d.argmin()]) if d.min() < ON_WALKER_PX else -1)
        out.append((t, np.array(rows_j).reshape(-1, 4), np.array(on, int), mem, who))
        prev = g
    return out


def least_gap(p: np.ndarray, q: np.ndarray) -> float:
    return float(np.sqrt(((p[:, None] - q[None]) ** 2).sum(-1)).min()) if len(p) and len(q) else math.nan


def main(path: str, seed: int, t0_s: float, t1_s: float) -> None:
    sc = load_scenario(path)
    m_per_px = 2 * sc.uav.altitude_agl_m * math.tan(math.radians(sc.camera.hfov_deg / 2)) / sc.camera.width_px
    right, rows = [], []
    for t, C, on, mem, who in follow(capture(path, seed, t0_s, t1_s)):
        moving = np.hypot(*C[:, :2].T) > MOVED_PX_S
        if (who == 1).sum() == 0 or moving.sum() < 6:
            continue
        truth_m = least_gap(mem[who == 0], mem[who == 1]) * m_per_px
        mine = moving & (on >= 0)
        by_walk = math.nan
        if len(set(on[mine])) == 2:
            med = np.array([np.median(C[mine & (on == k), :2], 0) for k in (0, 1)])
            given = np.argmin(((C[moving, None, :2] - med[None]) ** 2).sum(-1), 1)
            right.append(np.mean(given[on[moving] >= 0] == on[mine]))
            by_walk = least_gap(C[moving][given == 0, 2:], C[moving][given == 1, 2:]) * m_per_px
        _, half, _ = cv2.kmeans(C[moving, :2].astype(np.float32), 2, None,
                                (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 0.1), 5,
                                cv2.KMEANS_PP_CENTERS)
        half = half.ravel()
        xy = C[moving, 2:]
        rows.append((truth_m, least_gap(xy[half == 0], xy[half == 1]) * m_per_px,
                     least_gap(C[mine & (on == 0), 2:], C[mine & (on == 1), 2:]) * m_per_px, by_walk))
    R = np.array(rows)
    print(f"{len(R)} frames with both crowds in view and moving corners, {int((R[:, 0] < 2).sum())} of them mingling "
          f"by the scoring's rule; corners on walkers given the right crowd by the nearer crowd velocity: "
          f"{np.mean(right):.3f} (frame mean, {len(right)} frames)")
    for col, how in ((1, "2-means on velocity"), (3, "the nearer crowd velocity"),
                     (2, "each corner's own walker's crowd")):
        ok = ~np.isnan(R[:, col])
        for thr in (1.0, 1.5, 2.0, 2.5, 3.0):
            said, true = R[ok, col] < thr, R[ok, 0] < 2.0
            print(f"  corners split by {how}, mingling when under {thr} m: agrees with the rule in "
                  f"{np.mean(said == true):.3f} of {ok.sum()} frames ({int((said & ~true).sum())} said mingling when "
                  f"not, {int((~said & true).sum())} missed)")


if __name__ == "__main__":
    if len(sys.argv) != 5:
        raise SystemExit(__doc__)
    main(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]))
