"""Two crowds reported side by side with overlapping footprints that keep their distance: are their walkers within
the 2 m that makes them one crowd by the scenarios' rule? A probe for docs/results-worlds.md (session 38); not part
of the product. Use it on tuning seeds.

    .venv/bin/python docs/overlap_keep_probe.py ../shared/scenarios/field-alt100-lm6.toml 1 3
    .venv/bin/python docs/overlap_keep_probe.py scenarios/real-alt60-lm6-two.toml 1
    .venv/bin/python docs/overlap_keep_probe.py scenarios/real-alt60-lm6-two.toml 2 3 11 12 13 14 15 16

Runs each seed through the experiment (rendered frames, the deployed node classes; the frames of
``docs/mingling_gaps.py``: every frame with two crowds reported, the gap between their footprints, 0 or less when
they overlap, and whether any two walkers of the two crowds are within 2 m). Then, for a rule "join two crowds
whose footprints overlap by at least G m and whose distance changed by less than S m/s over the last W s" (a
straight line fitted to the distance, both reported in at least 80 % of those frames), prints how many frames it
would join and how many of those have the walkers within 2 m.
"""

import sys

import numpy as np

from mingling_gaps import one_seed

RULES = [(w, g, s) for w in (2.0, 4.0, 6.0) for g in (0.0, 0.5, 1.0) for s in (0.1, 0.2)]


def kept_distance(history: list, t: float, window_s: float, max_m_s: float, rate_hz: float = 10.0) -> bool:
    """Whether the distance in ``history`` ((time s, m), up to ``t``) changed by less than ``max_m_s``."""
    pts = np.array([(s, d) for s, d in history if t - window_s <= s <= t])
    if len(pts) < 0.8 * window_s * rate_hz or pts[0, 0] > t - 0.9 * window_s:
        return False
    return abs(np.polyfit(pts[:, 0] - t, pts[:, 1], 1)[0]) < max_m_s


def main(path: str, seeds: list[int]) -> None:
    rows = []
    for seed in seeds:
        seen: dict = {}
        for gap, close, t, pair, d in one_seed(path, seed):
            seen.setdefault(pair, []).append((t, d))
            rows.append((t, gap, close, list(seen[pair])))
    close = np.array([r[2] for r in rows], bool)
    print(f"{path} seeds {seeds}: {len(rows)} frames with two crowds reported, walkers within 2 m in {close.sum()}")
    for w, g, s in RULES:
        k = np.array([gap <= -g and kept_distance(h, t, w, s) for t, gap, _, h in rows], bool)
        print(f"  overlap >= {g:.1f} m, distance kept within {s:.1f} m/s over {w:.0f} s: joins {k.sum():4d} frames, "
              f"walkers within 2 m in {close[k].sum():4d}")


if __name__ == "__main__":
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    main(sys.argv[1], [int(s) for s in sys.argv[2:]])
