"""What a crowd velocity that does not follow its blob could buy, bounded from above: the grouping replayed on
recordings (`docs/grouping_replay.py record`) with each crowd seen placed through a complementary filter driven by
the true crowd's velocity, made worse as a measured one would be (slowed by ``BIAS``, white noise ``SIGMA_V`` m/s
per axis, and in a share ``OUTLIERS`` of frames another ``OUTLIER_SIGMA_V``): ``x <- x + v dt``, then
``x <- x + ALPHA (z - x)``, ``z`` the position the team reports now. One-crowd
worlds only; crowds held by their walk (step 6) are left as they are. A diagnostic for docs/results-worlds.md
(session 50); not part of the product.

    .venv/bin/python docs/velocity_oracle.py ALPHA BIAS SIGMA_V REC/*.pkl      # ALPHA 1: the recording as run
    .venv/bin/python docs/velocity_oracle.py ALPHA BIAS SIGMA_V OUTLIERS OUTLIER_SIGMA_V REC/*.pkl
"""

import os
import sys
from dataclasses import replace
from itertools import islice

import numpy as np

from grouping_replay import replay

GAP_S = 0.5     # a crowd unseen longer starts its filter afresh


def complementary(alpha: float, bias: float, sigma_v: float, rng: np.random.Generator, outliers: float = 0.0,
                  outlier_sigma_v: float = 0.0):
    """The ``adjust`` of :func:`grouping_replay.replay` that places each crowd seen by the filter above."""
    filt: dict[int, tuple[float, np.ndarray]] = {}

    def adjust(stamp_s, reported, truths, scorer):
        ones = list(islice((m for m in reversed(truths) if len(m.crowds) == 1), 2))[::-1]   # its last two truths
        if alpha >= 1.0 or len(ones) < 2:
            return reported
        (t0, p0), (t1, p1) = ((m.stamp_s, scorer._en([m.crowds[0].lat_deg], [m.crowds[0].lon_deg])[0]) for m in ones)
        v_true = (p1 - p0) / max(t1 - t0, 1e-3)
        out = []
        for r in reported:
            z = np.array([r.estimate.east_m, r.estimate.north_m])
            if r.unseen_s > 0.0:
                filt.pop(r.crowd_id, None)
                out.append(r)
                continue
            prev = filt.get(r.crowd_id)
            if prev is None or stamp_s - prev[0] > GAP_S:
                x = z
            else:
                v = v_true * (1.0 - bias) + rng.normal(0.0, sigma_v, 2)
                if outliers > 0.0 and rng.random() < outliers:
                    v = v + rng.normal(0.0, outlier_sigma_v, 2)
                x = prev[1] + v * (stamp_s - prev[0])
                x = x + alpha * (z - x)
            filt[r.crowd_id] = (stamp_s, x)
            out.append(replace(r, estimate=replace(r.estimate, east_m=float(x[0]), north_m=float(x[1]))))
        return out

    return adjust


def main(argv: list[str]) -> None:
    k = next((i for i, a in enumerate(argv) if a.endswith(".pkl")), len(argv))
    alpha, bias, sigma_v, outliers, outlier_sigma_v = ([float(v) for v in argv[:k]] + [0.0, 0.0])[:5]
    means, maxima = [], []
    for p in argv[k:]:
        board = replay(p, {}, complementary(alpha, bias, sigma_v, np.random.default_rng(1), outliers,
                                            outlier_sigma_v))
        e, t = np.asarray(board.errors_m), np.asarray(board.times_s)
        means.append(e.mean())
        maxima.append(e.max())
        print(f"{os.path.basename(p)[:-4]}: mean {e.mean():.3f} m, p95 {np.percentile(e, 95):.2f}, "
              f"max {e.max():.2f} at {t[e.argmax()]:.1f} s")
    print(f"{len(means)} recordings: mean of their means {np.mean(means):.3f} m, max {max(maxima):.2f} m")


if __name__ == "__main__":
    if len(sys.argv) < 5 or not sys.argv[-1].endswith(".pkl"):
        raise SystemExit(__doc__)
    main(sys.argv[1:])
