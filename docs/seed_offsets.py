"""What sets a seed's error level: per recording, the localizer's crowd estimates (before the grouping) against
the true crowd, their mean offset east / north and along / across the crowd's walk, the offset's 1 s means (RMS
per axis) and the share of frames inside the estimate's own 95 % radius (a diagnostic for
docs/results-worlds.md, session 46; not part of the product).

    .venv/bin/python docs/seed_offsets.py OUT_DIR/<scenario>__seed<N>.pkl ...

The recordings are `docs/grouping_replay.py record`'s; one-crowd worlds only (frames with one true crowd,
estimates within 10 m of it, pose-only estimates left out).
"""

import os
import pickle
import sys

import numpy as np

from uvteam.localizer import FitQuality


def main(paths: list[str]) -> None:
    for path in paths:
        with open(path, "rb") as f:
            rec = pickle.load(f)
        frame, truth, rows = rec["frame"], {}, []
        for kind, a, b in rec["events"]:
            if kind == "truth" and len(b.crowds) == 1:
                e, n = frame.wgs84_to_ground(np.array([b.crowds[0].lat_deg]), np.array([b.crowds[0].lon_deg]))
                truth[round(b.stamp_s, 3)] = np.array([e[0], n[0]])
            elif kind == "frame" and round(b, 3) in truth:
                t = round(b, 3)
                for est in a:
                    d = np.array([est.east_m, est.north_m]) - truth[t]
                    if est.quality != FitQuality.POSE and np.hypot(*d) <= 10.0:
                        rows.append((t, *d, est.radius95_m))
        r = np.array(rows)
        ts = np.array(sorted(truth))
        v = np.gradient(np.array([truth[t] for t in ts]), ts, axis=0)
        v_at = {t: v[i] for i, t in enumerate(ts)}
        along, across = [], []
        for t, de, dn, _ in r:
            s = float(np.hypot(*v_at[t]))
            u = v_at[t] / s if s > 0.2 else np.full(2, np.nan)
            along.append(de * u[0] + dn * u[1])
            across.append(-de * u[1] + dn * u[0])
        mean_1s = np.array([r[np.abs(r[:, 0] - t) <= 1.0, 1:3].mean(0) for t in r[:, 0]])
        err = np.hypot(r[:, 1], r[:, 2])
        print(f"{os.path.basename(path)[:-4]}: {len(r)} estimates, error mean {err.mean():.3f} p95 "
              f"{np.percentile(err, 95):.2f} m; offset east {r[:, 1].mean():+.2f} north {r[:, 2].mean():+.2f}, "
              f"along {np.nanmean(along):+.2f} across {np.nanmean(across):+.2f} m; 1 s means RMS "
              f"{np.sqrt((mean_1s ** 2).mean()):.2f} m per axis; in own radius {np.mean(err <= r[:, 3]):.3f}")


if __name__ == "__main__":
    main(sys.argv[1:])
