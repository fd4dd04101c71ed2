"""The one scorer: reported crowds against the truth, as ../shared/scenarios/README.md defines it. Pure.

Per frame in which crowds are present: reports are matched to true crowds by Hungarian assignment on
ground distance with a ``gate_m`` (10 m) gate; a match's error is that distance; unmatched reports are
false crowds (and "UGV as crowd" when a true UGV is within ``ugv_m``, 2 m), unmatched true crowds are
misses. Mingling crowds come already joined in the truth (the simulator scores them as one). Recall
counts (frame, true crowd) pairs from ``recall_after_s`` (1 s) after the first frame on. An id change
is a true crowd matched to a report whose crowd id differs from that of the report it was last matched
to (the true crowds known by their place in the truth while their number holds; a change of number,
crowds mingling or parting, starts afresh): what the team sees as one crowd becoming another.

:class:`Scoreboard` keeps one run's scores; :class:`BusScorer` pairs the ``truth`` and ``crowds``
messages of a run by their frame stamps and feeds a scoreboard, so the experiment (in-memory bus), the
demo (zenoh) and the benchmarks score the same way from the same messages.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from .geo import LocalFrame
from .messages import Crowds, Truth

__all__ = ["FrameScore", "score_frame", "Scoreboard", "BusScorer", "summarize", "SCORE_GATE_M", "UGV_AS_CROWD_M"]

SCORE_GATE_M = 10.0
UGV_AS_CROWD_M = 2.0
RECALL_AFTER_S = 1.0


@dataclass(frozen=True, slots=True)
class FrameScore:
    matches: tuple[tuple[int, int, float], ...]     # (report, true crowd, error m)
    false: tuple[int, ...]                           # reports matched to no true crowd
    ugv_distance_m: tuple[float, ...]                # per false report: distance to the nearest true UGV
    missed: tuple[int, ...]                          # true crowds no report matched


def score_frame(truth_en: np.ndarray, reported_en: np.ndarray, ugv_en: np.ndarray | None = None,
                gate_m: float = SCORE_GATE_M) -> FrameScore:
    """One frame: (T, 2) true crowd centroids, (R, 2) reports, (U, 2) true UGV positions, metres."""
    tru = np.asarray(truth_en, float).reshape(-1, 2)
    rep = np.asarray(reported_en, float).reshape(-1, 2)
    matches = []
    if len(rep) and len(tru):
        d = np.sqrt(((rep[:, None] - tru[None]) ** 2).sum(-1))
        for r, t in zip(*linear_sum_assignment(d)):
            if d[r, t] <= gate_m:
                matches.append((int(r), int(t), float(d[r, t])))
    got_r = {m[0] for m in matches}
    got_t = {m[1] for m in matches}
    false = tuple(r for r in range(len(rep)) if r not in got_r)
    ugv = np.asarray(ugv_en if ugv_en is not None else np.empty((0, 2)), float).reshape(-1, 2)
    ugv_d = tuple(float(np.sqrt(((ugv - rep[r]) ** 2).sum(1)).min()) if len(ugv) else math.inf for r in false)
    return FrameScore(tuple(matches), false, ugv_d, tuple(t for t in range(len(tru)) if t not in got_t))


@dataclass
class Scoreboard:
    """One run's scores, frame by frame (times relative to the run's first frame)."""

    scenario: str = ""
    seed: int = 0
    start_s: float | None = None
    times_s: list = field(default_factory=list)      # per matched (frame, crowd)
    errors_m: list = field(default_factory=list)
    radius95_m: list = field(default_factory=list)
    quality: list = field(default_factory=list)
    unseen_s: list = field(default_factory=list)     # 0: the crowd was seen in that frame; > 0: predicted
    truth_frames: int = 0                            # (frame, true crowd) pairs after the first second
    detected_frames: int = 0
    false_crowds: int = 0
    ugv_as_crowd: int = 0
    frames: int = 0
    frame_log: list = field(default_factory=list)    # per frame: (t, true crowds, matched, reported)
    false_log: list = field(default_factory=list)    # per false crowd: (t, east m, north m, distance to nearest UGV m)
    id_changes: int = 0                              # true crowds matched to a report of another id than last time
    last_ids: list = field(default_factory=list)     # per true crowd: the id it was last matched to (None: never)

    def add(self, stamp_s: float, truth_en, reported_en, radius95_m, quality, ugv_en=None, unseen_s=None,
            crowd_ids=None) -> FrameScore:
        if self.start_s is None:
            self.start_s = stamp_s
        t = stamp_s - self.start_s
        rep = np.asarray(reported_en, float).reshape(-1, 2)
        fs = score_frame(truth_en, rep, ugv_en)
        self.frames += 1
        for r, _, err in fs.matches:
            self.times_s.append(t)
            self.errors_m.append(err)
            self.radius95_m.append(float(radius95_m[r]))
            self.quality.append(quality[r])
            self.unseen_s.append(0.0 if unseen_s is None else float(unseen_s[r]))
        n_truth = len(fs.matches) + len(fs.missed)
        if crowd_ids is not None:
            if len(self.last_ids) != n_truth:
                self.last_ids = [None] * n_truth
            for r, k, _ in fs.matches:
                self.id_changes += self.last_ids[k] is not None and self.last_ids[k] != crowd_ids[r]
                self.last_ids[k] = int(crowd_ids[r])
        for r, dist in zip(fs.false, fs.ugv_distance_m):
            self.false_crowds += 1
            self.ugv_as_crowd += int(dist < UGV_AS_CROWD_M)
            self.false_log.append((t, float(rep[r, 0]), float(rep[r, 1]), dist))
        self.frame_log.append((t, n_truth, len(fs.matches), len(rep)))
        if t >= RECALL_AFTER_S - 1e-9:
            self.truth_frames += n_truth
            self.detected_frames += len(fs.matches)
        return fs


def summarize(boards: list[Scoreboard]) -> dict:
    """mean/median/p95/max error, recall, false crowds, UGV-as-crowd and 95 % coverage over runs."""
    e = np.concatenate([np.asarray(b.errors_m, float) for b in boards]) if boards else np.empty(0)
    r95 = np.concatenate([np.asarray(b.radius95_m, float) for b in boards]) if boards else np.empty(0)
    tf = sum(b.truth_frames for b in boards)
    return {
        "n": int(len(e)),
        "mean_m": float(e.mean()) if len(e) else math.nan,
        "median_m": float(np.median(e)) if len(e) else math.nan,
        "p95_m": float(np.percentile(e, 95)) if len(e) else math.nan,
        "max_m": float(e.max()) if len(e) else math.nan,
        "recall": sum(b.detected_frames for b in boards) / tf if tf else math.nan,
        "predicted": int(sum(np.count_nonzero(np.asarray(b.unseen_s, float) > 0) for b in boards)),
        "false_crowds": sum(b.false_crowds for b in boards),
        "ugv_as_crowd": sum(b.ugv_as_crowd for b in boards),
        "frames": sum(b.frames for b in boards),
        "coverage95": float(np.mean(e <= r95)) if len(e) else math.nan,
        "id_changes": sum(b.id_changes for b in boards),
    }


class BusScorer:
    """Scores a run from its messages: ``on_truth`` and ``on_crowds`` are bus handlers; a frame is scored
    when both its messages are in, and :meth:`finish` scores the truth frames no crowds message answered
    (every true crowd missed). Positions are compared in ``frame`` (east-north metres)."""

    def __init__(self, frame: LocalFrame, board: Scoreboard | None = None) -> None:
        self.frame = frame
        self.board = board or Scoreboard()
        self.lock = threading.Lock()
        self.truth: dict[int, Truth] = {}
        self.crowds: dict[int, Crowds] = {}
        self.last: tuple[Truth, Crowds, FrameScore] | None = None

    @staticmethod
    def _ms(stamp_s: float) -> int:
        return int(round(stamp_s * 1000))

    def on_truth(self, key: str, t: Truth) -> None:
        with self.lock:
            if self.board.start_s is None:   # the run starts at its first frame, answered or not
                self.board.start_s = t.stamp_s
            self.truth[self._ms(t.stamp_s)] = t
            self._score(self._ms(t.stamp_s))

    def on_crowds(self, key: str, c: Crowds) -> None:
        with self.lock:
            self.crowds[self._ms(c.stamp_s)] = c
            self._score(self._ms(c.stamp_s))

    def _en(self, lat, lon) -> np.ndarray:
        e, n = self.frame.wgs84_to_ground(np.asarray(lat, float), np.asarray(lon, float))
        return np.column_stack([e, n]).reshape(-1, 2)

    def _score(self, ms: int) -> None:
        t, c = self.truth.get(ms), self.crowds.get(ms)
        if t is None or c is None:
            return
        del self.truth[ms], self.crowds[ms]
        self._add(t, c)

    def _add(self, t: Truth, c: Crowds | None) -> None:
        crowds = c.crowds if c is not None else ()
        fs = self.board.add(t.stamp_s, self._en([x.lat_deg for x in t.crowds], [x.lon_deg for x in t.crowds]),
                            self._en([x.lat_deg for x in crowds], [x.lon_deg for x in crowds]),
                            [x.radius95_m for x in crowds], [x.quality for x in crowds],
                            self._en([u.lat_deg for u in t.ugvs], [u.lon_deg for u in t.ugvs]),
                            [x.unseen_s for x in crowds], [x.crowd_id for x in crowds])
        if c is not None:
            self.last = (t, c, fs)

    def finish(self) -> Scoreboard:
        """Scores the truth frames still unanswered (in stamp order) and returns the scoreboard."""
        with self.lock:
            for ms in sorted(self.truth):
                self._add(self.truth.pop(ms), None)
            self.crowds.clear()
        return self.board
