"""What the walkers' velocity the team measures is worth: on recordings (`docs/grouping_replay.py record`, the deployed
path), each frame's biggest crowd estimate's ground velocity (``CrowdEstimate.v_en_m_s``, from the UAV's corners on
the walkers, `uvteam.vision.blob_velocity`) against the truth's crowd velocity over the last 0.5 s; one-crowd frames
only. Per recording: the share of frames measured, the speed ratio's median, the median absolute error and RMS per
axis; then, over all recordings, the error by the spread the detector declared (its quartiles and top tenth).
A diagnostic for docs/results-worlds.md (session 51); not part of the product.

    .venv/bin/python docs/velocity_check.py REC/*.pkl
"""

import os
import pickle
import sys

import numpy as np

from uvteam.scoring import BusScorer, Scoreboard

BACK = 5    # truth messages: 0.5 s at 10 Hz


def rows_of(path: str) -> tuple[list[tuple], int]:
    """(truth velocity east, north, measured east, north, declared spread) per frame measured; frames seen."""
    with open(path, "rb") as f:
        rec = pickle.load(f)
    scorer = BusScorer(rec["scored_in"], Scoreboard())
    truths, rows, seen = [], [], 0
    for kind, a, b in rec["events"]:
        if kind == "truth":
            truths.append(b)
        elif kind == "frame" and len(truths) > BACK and a:
            t0, t1 = truths[-1 - BACK], truths[-1]
            if len(t0.crowds) != 1 or len(t1.crowds) != 1:
                continue
            p0, p1 = (scorer._en([m.crowds[0].lat_deg], [m.crowds[0].lon_deg])[0] for m in (t0, t1))
            v_true = (p1 - p0) / max(t1.stamp_s - t0.stamp_s, 1e-3)
            c = max(a, key=lambda e: e.area_px)
            seen += 1
            if c.v_en_m_s is not None:
                rows.append((*v_true, *c.v_en_m_s, c.sigma_v_m_s))
    return rows, seen


def main(paths: list[str]) -> None:
    every = []
    for p in paths:
        rows, seen = rows_of(p)
        if not rows:
            print(f"{os.path.basename(p)}: no velocity measured in {seen} frames")
            continue
        r = np.array(rows)
        every.append(r)
        d = r[:, 2:4] - r[:, 0:2]
        ratio = np.hypot(*r[:, 2:4].T) / np.maximum(np.hypot(*r[:, 0:2].T), 1e-3)
        print(f"{os.path.basename(p)}: measured in {len(r)}/{seen} frames, speed ratio median {np.median(ratio):.2f}, "
              f"median absolute error {np.median(np.abs(d), 0).round(3)} m/s, RMS {np.sqrt((d ** 2).mean(0)).round(3)}")
    if not every:
        return
    r = np.vstack(every)
    err, spread = np.hypot(*(r[:, 2:4] - r[:, 0:2]).T), r[:, 4]
    q = np.quantile(spread, [0.0, 0.25, 0.5, 0.75, 0.9, 1.0])
    for lo, hi in zip(q[:-1], q[1:]):
        m = (spread >= lo) & (spread <= hi)
        print(f"declared spread {lo:.3f}-{hi:.3f} m/s: {m.sum()} frames, error median {np.median(err[m]):.2f} m/s, "
              f"90th percentile {np.percentile(err[m], 90):.2f}")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    main(sys.argv[1:])
