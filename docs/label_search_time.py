"""The roof-label search's cost per frame in the deployed UAV pipeline: searched in windows round each
UGV's expected and last place (most frames) against the whole frame (acquisition, every
``ACQUIRE_EVERY`` frames), side by side on the same frames. A measurement for docs/performance.md
(session 9), not a timed test.

    .venv/bin/python docs/label_search_time.py scenarios/real-alt60-lm6.toml 1 20

Runs the first ``DURATION`` seconds of one seed through the experiment (rendered frames, the deployed
node classes, one core); wherever the pipeline calls :func:`uvteam.vision.landmarks.label_candidates`,
the call is timed as made and again on the same frame with no window (the whole frame), in
alternating order. Prints per-frame medians and the mean over the frames as the pipeline runs them; and
(session 43) the choice among the candidates that follows each search (``UavVision._choose``: the prediction's
gate, what moved, the label tracks of :mod:`uvteam.vision.label_tracks`), timed as run, and the two together.
"""

import json
import sys
import time

import cv2
import numpy as np

import uvteam.vision.uav as uav_module
from uvteam.io.files import load_scenario
from uvteam.vision.uav import ACQUIRE_EVERY
from uvteam_sim.experiment import SimTeam


def main(path: str, seed: int, duration_s: float) -> dict:
    cv2.setNumThreads(1)
    search = uav_module.label_candidates
    as_run, whole, windowed = [], [], []

    def timed(frame, cfg, wanted=None, windows=None):
        calls = [("run", windows), ("whole", None)]
        if len(as_run) % 2:
            calls.reverse()
        for which, win in calls:
            t0 = time.perf_counter()
            got = search(frame, cfg, wanted, win)
            dt_ms = (time.perf_counter() - t0) * 1e3
            if which == "run":
                as_run.append(dt_ms)
                windowed.append(bool(windows))
                result = got
            else:
                whole.append(dt_ms)
        return result

    choose = uav_module.UavVision._choose
    chose = []

    def timed_choose(self, *args, **kwargs):
        t0 = time.perf_counter()
        got = choose(self, *args, **kwargs)
        chose.append((time.perf_counter() - t0) * 1e3)
        return got

    uav_module.label_candidates = timed
    uav_module.UavVision._choose = timed_choose
    sc = load_scenario(path)
    SimTeam(sc, seed, "pixels").run(duration_s)
    run_ms, whole_ms, win = np.array(as_run), np.array(whole), np.array(windowed)
    choose_ms = np.array(chose)
    return {"scenario": sc.name, "seed": seed, "frames": len(run_ms), "acquire_every": ACQUIRE_EVERY,
            "windowed_frames": int(win.sum()),
            "windowed_ms_p50": round(float(np.median(run_ms[win])), 3) if win.any() else None,
            "windowed_ms_p95": round(float(np.percentile(run_ms[win], 95)), 3) if win.any() else None,
            "whole_frame_ms_p50": round(float(np.median(whole_ms)), 3),
            "ratio_whole_over_windowed": (round(float(np.median(whole_ms[win]) / np.median(run_ms[win])), 1)
                                          if win.any() else None),
            "mean_ms_per_frame_as_run": round(float(run_ms.mean()), 3),
            "choose_ms_p50": round(float(np.median(choose_ms)), 3),
            "choose_ms_p95": round(float(np.percentile(choose_ms, 95)), 3),
            "search_and_choose_mean_ms_per_frame": round(float(run_ms.mean() + choose_ms.mean()), 3),
            "date": time.strftime("%Y-%m-%d")}


if __name__ == "__main__":
    print(json.dumps(main(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]) if len(sys.argv) > 3 else 20.0)))
