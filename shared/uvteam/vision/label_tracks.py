"""Roof-label tracks: whether a label-colored blob moves as its UGV reports. No I/O, no clock.

A UGV's roof label is looked for by color near where its fix says it is (:mod:`uvteam.vision.uav`). A patch of the
same color on the ground near it (paint, a parked car, a roof) passes that test too when the prediction is loose,
as it is through the camera's pose alone (several metres at 120 m), and it lies on moving pixels whenever its UGV
drives past. What a patch cannot do is move as the UGV reports. So each color's candidates are followed from frame to
frame, carried by the camera's registration (so a track's displacement is over the ground, not the camera's), and
compared with the UGV's own displacement: its receiver's velocity in pixels, each sample at its fix's capture time
(fixes arrive late, and a UGV turns meanwhile), linear between samples, integrated up to the newest one. A check
passes when the two agree within half the UGV's displacement plus the label's noise; a span across a turn between
two fixes gives no verdict. Every frame checks the shortest span back in which the UGV covered ``check_min_m``: a
failure *refutes* a track (a confirmed one only after ``refute_after`` failures in a row). A track is *confirmed*
only once checks have agreed over ``confirm_min_m`` of the UGV's way with no failure since; until then, or while
the UGV has not moved that far, it is *pending*. The short span alone is not enough: at 120 m its 0.8 m is five
pixels, about how far a still patch's visible centre jumps while its UGV drives over it (docs/results-worlds.md,
sessions 43-44). Only a confirmed track's label is a landmark. A still UGV's label is one only if its track was
confirmed while the UGV moved and followed since: a still label and a patch of paint look alike, and no test on one
frame tells them apart.
"""

from __future__ import annotations

import bisect
import itertools
import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["LabelTrackConfig", "LabelTracks", "PENDING", "CONFIRMED", "REFUTED"]

PENDING, CONFIRMED, REFUTED = "pending", "confirmed", "refuted"


@dataclass(frozen=True, slots=True)
class LabelTrackConfig:
    window_s: float = 4.0            # a track's displacement is checked over at most this span
    check_min_m: float = 0.8         # ... once its UGV has covered this much ground in it
    confirm_min_m: float = 2.5       # a track is confirmed by checks that agree, none failing, over this much
    agree_fraction: float = 0.5      # the track and its UGV agree within this fraction of the UGV's displacement
    noise_m: float = 0.3             # ... plus this (the label's centroid and the registration's drift)
    noise_min_px: float = 2.0
    unsure_fraction: float = 0.25    # no verdict when where the UGV went between its fixes is this unsure
    reach_m: float = 2.0             # a track takes a candidate this near where it should be now
    speed_slack_m_s: float = 1.0     # ... plus this per second unseen (the reported velocity's error)
    max_gap_s: float = 1.5           # velocity samples further apart than this say nothing of between them
    unknown_speed_m_s: float = 6.0   # ... or this per second over frames without the UGV's velocity
    refute_after: int = 3            # a confirmed track is refuted after this many failed checks in a row
    keep_s: float = 0.5              # a pending or refuted track unseen this long is dropped
    confirmed_keep_s: float = 3.0    # a confirmed one this long


@dataclass(slots=True)
class _Track:
    points: list[tuple[float, float, float]]   # (stamp, x, y), in the current frame's pixels
    state: str = PENDING
    seen_s: float = 0.0
    failed: int = 0                            # failed checks in a row
    failed_s: float = -math.inf                # the newest failed check's time
    agree_from_s: float | None = None          # where the short spans that agreed since then began

    @property
    def last_xy(self) -> np.ndarray:
        return np.array(self.points[-1][1:])


class _Motion:
    """A UGV's velocity samples (in pixels per second, at the times they were measured) as its displacement
    between any two times: linear between samples, held after the newest with ``hold``, unknown (None) before
    the oldest or across a gap of over ``max_gap_s``. Plain Python, kept up to date sample by sample: a few dozen
    samples, asked a few dozen times a frame, where NumPy's per-call cost was most of the time."""

    def __init__(self, max_gap_s: float) -> None:
        self.max_gap_s = max_gap_s
        self.ts: list[float] = []
        self.v: list[tuple[float, float]] = []
        # per sample, from the one before: the displacement (the line between them) and, for a step at either end
        # of the interval instead of the line, half the change times the interval; summed from the oldest sample
        self._inc_x: list[float] = []
        self._inc_y: list[float] = []
        self._inc_u: list[float] = []
        self._gap: list[bool] = []
        self.cum: list[tuple[float, float]] = []
        self.unsure_cum: list[float] = []
        self.known_from = math.inf

    def _increments(self, k: int) -> None:
        if k == 0:
            self._inc_x[0] = self._inc_y[0] = self._inc_u[0] = 0.0
            self._gap[0] = False
            return
        dt = self.ts[k] - self.ts[k - 1]
        (ax, ay), (bx, by) = self.v[k - 1], self.v[k]
        self._inc_x[k], self._inc_y[k] = 0.5 * (ax + bx) * dt, 0.5 * (ay + by) * dt
        self._inc_u[k] = 0.5 * math.hypot(bx - ax, by - ay) * dt
        self._gap[k] = dt > self.max_gap_s

    def _sums(self) -> None:
        self.cum = list(zip(itertools.accumulate(self._inc_x), itertools.accumulate(self._inc_y)))
        self.unsure_cum = list(itertools.accumulate(self._inc_u))
        last_gap = max((k for k, g in enumerate(self._gap) if g), default=0)
        self.known_from = self.ts[last_gap] if self.ts else math.inf

    def add(self, stamp_s: float, v_px_s, now_s: float, keep_s: float) -> None:
        """A sample measured at ``stamp_s`` (replacing one of the same time); samples older than ``keep_s``
        before ``now_s`` are dropped."""
        v = (float(v_px_s[0]), float(v_px_s[1]))
        stamp_s = float(stamp_s)
        if self.ts and self.ts[-1] < stamp_s:       # the usual case: a newer fix; the oldest dropped as they age
            n_old = next((k for k, s in enumerate(self.ts) if now_s - s <= keep_s), len(self.ts))
            if n_old:
                for lst in (self.ts, self.v, self._inc_x, self._inc_y, self._inc_u, self._gap):
                    del lst[:n_old]
                if self.ts:
                    self._increments(0)
            self.ts.append(stamp_s)
            self.v.append(v)
            for lst in (self._inc_x, self._inc_y, self._inc_u):
                lst.append(0.0)
            self._gap.append(False)
            self._increments(len(self.ts) - 1)
        else:
            pairs = sorted([(s, vv) for s, vv in zip(self.ts, self.v) if s != stamp_s and now_s - s <= keep_s]
                           + [(stamp_s, v)], key=lambda sv: sv[0])
            self.ts, self.v = [s for s, _ in pairs], [vv for _, vv in pairs]
            n = len(self.ts)
            self._inc_x, self._inc_y, self._inc_u, self._gap = [0.0] * n, [0.0] * n, [0.0] * n, [False] * n
            for k in range(n):
                self._increments(k)
        self._sums()

    @property
    def newest_s(self) -> float | None:
        return self.ts[-1] if self.ts else None

    def at(self, t: float, hold: bool = False) -> tuple[float, float] | None:
        """The displacement from the oldest sample to ``t``, or None where unknown."""
        ts, v, n = self.ts, self.v, len(self.ts)
        if not n or t < self.known_from - 1e-6 or (t > ts[-1] + 1e-6 and not hold):
            return None
        if t >= ts[-1] - 1e-9:
            (cx, cy), (vx, vy), dt = self.cum[-1], v[-1], t - ts[-1]
            return cx + vx * dt, cy + vy * dt
        i = min(max(bisect.bisect_right(ts, t) - 1, 0), n - 2)
        dt, h = t - ts[i], ts[i + 1] - ts[i]
        (ax, ay), (bx, by), (cx, cy) = v[i], v[i + 1], self.cum[i]
        return (cx + ax * dt + 0.5 * (bx - ax) / h * dt * dt, cy + ay * dt + 0.5 * (by - ay) / h * dt * dt)

    def between(self, t0: float, t1: float, hold: bool = False) -> tuple[float, float] | None:
        a, b = self.at(t0), self.at(t1, hold)
        return None if a is None or b is None else (b[0] - a[0], b[1] - a[1])

    def unsure(self, t0: float, t1: float) -> float:
        """How far off a displacement from ``t0`` to ``t1`` may be, in pixels, for not knowing when between two
        samples the velocity changed (over the samples the span touches)."""
        n = len(self.ts)
        a = max(bisect.bisect_right(self.ts, t0) - 1, 0)
        b = min(bisect.bisect_left(self.ts, t1), n - 1)
        return self.unsure_cum[b] - self.unsure_cum[a] if b > a else 0.0


@dataclass(slots=True)
class _Color:
    tracks: list[_Track] = field(default_factory=list)
    motion: _Motion | None = None                  # its UGV's velocity samples


class LabelTracks:
    """Each color's candidate tracks. Per frame: :meth:`carry` the stored points by the camera's motion, then
    :meth:`update` each color with its candidates, in that order."""

    def __init__(self, cfg: LabelTrackConfig = LabelTrackConfig()) -> None:
        self.cfg = cfg
        self._colors: dict[str, _Color] = {}

    def carry(self, to_this_frame) -> None:
        """Move every stored point into this frame: ``to_this_frame`` maps (N, 2) pixels of the previous frame."""
        tracks = [t for c in self._colors.values() for t in c.tracks]
        pts = [p for t in tracks for p in t.points]
        if not pts:
            return
        xy = to_this_frame(np.array([p[1:] for p in pts], float)).tolist()   # one call for every point
        k = 0
        for t in tracks:
            n = len(t.points)
            t.points = [(p[0], x, y) for p, (x, y) in zip(t.points, xy[k:k + n])]
            k += n

    def state_of(self, color: str) -> list[str]:
        return [t.state for t in self._colors.get(color, _Color()).tracks]

    def update(self, color: str, stamp_s: float, cands_xy_px: np.ndarray, velocity_px_s: np.ndarray | None,
               px_per_m: float, prefer_xy_px: np.ndarray | None = None, start: bool = True,
               velocity_stamp_s: float | None = None) -> tuple[int | None, str]:
        """This frame's candidates of ``color`` (N, 2), already gated by the prediction, and its UGV's velocity
        in pixels per second (None when not known this frame) as measured at ``velocity_stamp_s`` (its fix's
        time; this frame's by default). Returns the index of the candidate that is the label (a confirmed
        track's; of several, the nearest ``prefer_xy_px``), or None and why: ``unconfirmed``
        (its track's UGV has not moved enough yet to tell), ``moved_unlike_ugv`` (every track was refuted),
        ``no_track`` (candidates, none on a track, and ``start`` False). New tracks start only when ``start``."""
        cfg = self.cfg
        c = self._colors.setdefault(color, _Color())
        if velocity_px_s is not None:
            if c.motion is None:
                c.motion = _Motion(cfg.max_gap_s)
            c.motion.add(stamp_s if velocity_stamp_s is None else velocity_stamp_s, velocity_px_s, stamp_s,
                         cfg.window_s + cfg.confirmed_keep_s)
        c.tracks = [t for t in c.tracks
                    if stamp_s - t.seen_s <= (cfg.confirmed_keep_s if t.state == CONFIRMED else cfg.keep_s)]
        cands = np.asarray(cands_xy_px, float).reshape(-1, 2)
        # each track takes the nearest candidate to where it should be now, nearest pairs first
        pairs = []
        for i, t in enumerate(c.tracks):
            moved = c.motion.between(t.seen_s, stamp_s, hold=True) if c.motion is not None else None
            unseen_s = stamp_s - t.seen_s
            if moved is None:
                moved, slack = (0.0, 0.0), cfg.unknown_speed_m_s
            else:
                slack = cfg.speed_slack_m_s
            reach = (cfg.reach_m + slack * unseen_s) * px_per_m
            d = np.hypot(*(cands - (t.last_xy + np.array(moved))).T) if len(cands) else np.zeros(0)
            pairs += [(float(d[j]), i, j) for j in range(len(cands)) if d[j] <= reach]
        track_of: dict[int, int] = {}            # candidate -> its track
        for _, i, j in sorted(pairs):
            if i in track_of.values() or j in track_of:
                continue
            track_of[j] = i
            t = c.tracks[i]
            t.points.append((stamp_s, float(cands[j, 0]), float(cands[j, 1])))
            t.seen_s = stamp_s
            t.points = [p for p in t.points if stamp_s - p[0] <= cfg.window_s]
            t.state = self._check(c, t, px_per_m)
        if start:
            for j in range(len(cands)):
                if j not in track_of:
                    c.tracks.append(_Track([(stamp_s, float(cands[j, 0]), float(cands[j, 1]))], PENDING, stamp_s))
        good = [j for j, i in track_of.items() if c.tracks[i].state == CONFIRMED]
        if good:
            if prefer_xy_px is None:
                return good[0], ""
            return min(good, key=lambda j: float(np.hypot(*(cands[j] - prefer_xy_px)))), ""
        if not len(cands):
            return None, ""
        states = [c.tracks[i].state for i in track_of.values()]
        if states and all(s == REFUTED for s in states) and len(states) == len(cands):
            return None, "moved_unlike_ugv"
        return None, "unconfirmed" if (states or start) else "no_track"

    def _check(self, c: _Color, t: _Track, px_per_m: float) -> str:
        """A track's state after its newest point, from its displacement against its UGV's up to the newest
        velocity sample (:meth:`_agrees`). Each frame checks the shortest span back in which the UGV covered
        ``check_min_m``: a failure refutes a track not yet confirmed and, ``refute_after`` in a row, a confirmed
        one (one frame's blob cut by a passing walker is not a lie). A track is confirmed only once its checks
        have agreed over ``confirm_min_m`` of the UGV's way with no failure since: on one span that long, or on
        the short spans one after another (a UGV too slow to cover it within ``window_s``). Over a short span
        alone, a still patch the UGV drives over passes: its visible centre moves as the UGV hides and uncovers
        it, and at 120 m 0.8 m is five pixels (docs/results-worlds.md, sessions 43-44)."""
        cfg = self.cfg
        m = c.motion
        if m is None or m.newest_s is None:
            return t.state
        ts = [p[0] for p in t.points]
        t1 = min(ts[-1], m.newest_s)
        short = self._agrees(t, m, ts, t1, cfg.check_min_m * px_per_m, px_per_m)
        if short is False:
            t.failed += 1
            t.agree_from_s, t.failed_s = None, ts[-1]
            return REFUTED if t.state != CONFIRMED or t.failed >= cfg.refute_after else CONFIRMED
        if short is not None:
            t.failed = 0
        if t.state == CONFIRMED:
            return CONFIRMED
        long = self._agrees(t, m, ts, t1, cfg.confirm_min_m * px_per_m, px_per_m)
        if long is False:
            t.agree_from_s, t.failed_s = None, ts[-1]
            return REFUTED
        if long is not None and long >= t.failed_s:
            return CONFIRMED
        if short is None:
            return t.state
        t.agree_from_s = short if t.agree_from_s is None else min(t.agree_from_s, short)
        run = m.between(t.agree_from_s, t1)
        if run is None:                         # the UGV's velocity not known back to then: the run starts anew
            t.agree_from_s, run = short, m.between(short, t1)
        return CONFIRMED if run is not None and math.hypot(*run) >= cfg.confirm_min_m * px_per_m else PENDING

    def _agrees(self, t: _Track, m: _Motion, ts: list[float], t1: float, min_px: float,
                px_per_m: float) -> float | bool | None:
        """Whether the track moved as its UGV over the shortest span back to ``t1`` in which the UGV covered
        ``min_px``: the span's start time when within ``agree_fraction`` of the UGV's displacement plus the
        label's noise, False when not, None for no verdict (the UGV not that far within the track's points, its
        velocity unknown over the span, or where it went unsure: it turned between two fixes)."""
        cfg = self.cfg
        d1 = m.at(t1)
        if d1 is None:
            return None
        k_end = bisect.bisect_left(ts, t1)       # the points before t1
        for k in range(k_end - 1, -1, -1):
            d0 = m.at(ts[k])
            if d0 is None:
                return None                     # the UGV's velocity is not known over any longer span either
            expected = (d1[0] - d0[0], d1[1] - d0[1])
            e = math.hypot(*expected)
            if e >= min_px:
                break
        else:
            return None
        if m.unsure(ts[k], t1) > cfg.unsure_fraction * e:
            return None
        j = k_end                               # the track's place at t1, between two frames' points
        if j >= len(ts) or ts[j] == t1:
            x1, y1 = t.points[min(j, len(ts) - 1)][1:]
        else:
            (ta, xa, ya), (tb, xb, yb) = t.points[j - 1], t.points[j]
            f = (t1 - ta) / (tb - ta)
            x1, y1 = xa + f * (xb - xa), ya + f * (yb - ya)
        err = math.hypot(x1 - t.points[k][1] - expected[0], y1 - t.points[k][2] - expected[1])
        noise = max(cfg.noise_min_px, cfg.noise_m * px_per_m)
        return ts[k] if err <= cfg.agree_fraction * e + noise else False
