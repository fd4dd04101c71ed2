"""What step 10 of :mod:`uvteam.crowds` (each crowd reported through a constant-velocity filter) costs per frame:
:func:`uvteam.crowds.report_crowds` over recordings of `docs/grouping_replay.py record`, with the filter off and
on, alternately, three times each, in one process; the best of each and their ratio. A benchmark for
docs/results-worlds.md (session 41); not part of the product.

    .venv/bin/python docs/grouping_cost.py REC/field-alt100-lm6__seed*.pkl
"""

import pickle
import sys
import time

from grouping_replay import recorded_events
from uvteam.crowds import GroupingConfig, GroupingState, report_crowds


def per_frame_us(recordings: list[dict], accel_m_s2: float) -> float:
    frames, t0 = 0, time.perf_counter()
    for rec in recordings:
        cfg = GroupingConfig(confirm_hits=rec["confirm_hits"], smooth_accel_m_s2=accel_m_s2)
        state = GroupingState()
        for kind, estimates, stamp_s, shift in recorded_events(rec):
            if kind == "frame":
                state, _ = report_crowds(state, estimates, stamp_s, cfg, shift)
                frames += 1
    return (time.perf_counter() - t0) / frames * 1e6


def main(paths: list[str]) -> None:
    recordings = []
    for p in paths:
        with open(p, "rb") as f:
            recordings.append(pickle.load(f))
    best = {0.0: float("inf"), GroupingConfig().smooth_accel_m_s2: float("inf")}
    for _ in range(3):
        for accel in best:
            best[accel] = min(best[accel], per_frame_us(recordings, accel))
    off, on = best.values()
    print(f"report_crowds per frame: filter off {off:.0f} us, on {on:.0f} us, ratio {on / off:.3f} (best of 3)")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    main(sys.argv[1:])
