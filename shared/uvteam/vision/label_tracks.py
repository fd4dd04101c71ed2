"""Roof-label tracks: whether a label-colored blob moves as its UGV reports. No I/O, no clock.

A UGV's roof label is looked for by color near where its fix says it is (:mod:`uvteam.vision.uav`). A patch of the
same color on the ground near it (paint, a parked car, a roof) passes that test too when the prediction is loose,
as it is through the camera's pose alone (several metres at 120 m), and it lies on moving pixels whenever its UGV
drives past. What a patch cannot do is move as the UGV reports. So each color's candidates are followed from frame to
frame, carried by the camera's registration (so a track's displacement is over the ground, not the camera's), and a
track's displacement is compared with its UGV's over the same frames (the UGV's reported velocity in pixels, summed
frame by frame) over the shortest recent span, within ``window_s``, in which the UGV covered ``check_min_m``: the
track is *confirmed* when the two agree within half the UGV's displacement plus the label's noise and *refuted* when
they do not; until the UGV has moved that much it is *pending*. Only a confirmed track's label is a landmark. A still UGV's label is one only if its
track was confirmed while the UGV moved and followed since: a still label and a patch of paint look alike, and no
test on one frame tells them apart.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["LabelTrackConfig", "LabelTracks", "PENDING", "CONFIRMED", "REFUTED"]

PENDING, CONFIRMED, REFUTED = "pending", "confirmed", "refuted"


@dataclass(frozen=True, slots=True)
class LabelTrackConfig:
    window_s: float = 1.5            # a track's displacement is checked over at most this span
    check_min_m: float = 0.8         # ... once its UGV has covered this much ground in it
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

    @property
    def last_xy(self) -> np.ndarray:
        return np.array(self.points[-1][1:])


@dataclass(slots=True)
class _Color:
    tracks: list[_Track] = field(default_factory=list)
    velocity: list[tuple[float, np.ndarray]] = field(default_factory=list)   # (when measured, px/s), by time


class LabelTracks:
    """Each color's candidate tracks. Per frame: :meth:`carry` the stored points by the camera's motion, then
    :meth:`update` each color with its candidates, in that order."""

    def __init__(self, cfg: LabelTrackConfig = LabelTrackConfig()) -> None:
        self.cfg = cfg
        self._colors: dict[str, _Color] = {}

    def carry(self, to_this_frame) -> None:
        """Move every stored point into this frame: ``to_this_frame`` maps (N, 2) pixels of the previous frame."""
        for c in self._colors.values():
            for t in c.tracks:
                xy = to_this_frame(np.array([p[1:] for p in t.points]))
                t.points = [(p[0], float(x), float(y)) for p, (x, y) in zip(t.points, xy)]

    def state_of(self, color: str) -> list[str]:
        return [t.state for t in self._colors.get(color, _Color()).tracks]

    def _expected(self, c: _Color, t0_s: float, t1_s: float, hold: bool = False) -> np.ndarray | None:
        """The UGV's displacement in pixels from ``t0_s`` to ``t1_s``: its velocity, linear between samples,
        integrated. None where the samples do not span the interval (or leave a gap over ``max_gap_s`` in it);
        with ``hold``, the newest sample is held up to ``t1_s``."""
        vs = c.velocity
        if not vs or t1_s <= t0_s:
            return None if not vs else np.zeros(2)
        ts = np.array([s for s, _ in vs])
        v = np.array([vv for _, vv in vs])
        if hold and t1_s > ts[-1]:
            ts, v = np.r_[ts, t1_s], np.vstack([v, v[-1]])
        if ts[0] > t0_s + 1e-6 or ts[-1] < t1_s - 1e-6:
            return None
        a, b = np.searchsorted(ts, t0_s, "right") - 1, np.searchsorted(ts, t1_s, "left")
        if len(ts) > 1 and np.diff(ts[max(a, 0):b + 1]).max(initial=0.0) > self.cfg.max_gap_s:
            return None
        inner = (ts > t0_s) & (ts < t1_s)
        t = np.r_[t0_s, ts[inner], t1_s]
        vx = np.interp(t, ts, v[:, 0])
        vy = np.interp(t, ts, v[:, 1])
        dt = np.diff(t)
        return np.array([np.sum(0.5 * (vx[1:] + vx[:-1]) * dt), np.sum(0.5 * (vy[1:] + vy[:-1]) * dt)])

    def _unsure(self, c: _Color, t0_s: float, t1_s: float) -> float:
        """How far off :meth:`_expected` may be, in pixels, for not knowing when between two samples the velocity
        changed: half of each change times its interval (a step at either end), over the samples the interval
        touches. A UGV turning sharply between two fixes makes it large."""
        ts = np.array([s for s, _ in c.velocity])
        v = np.array([vv for _, vv in c.velocity])
        a = max(int(np.searchsorted(ts, t0_s, "right")) - 1, 0)
        b = min(int(np.searchsorted(ts, t1_s, "left")), len(ts) - 1)
        if b <= a:
            return 0.0
        return float(np.sum(0.5 * np.hypot(*np.diff(v[a:b + 1], axis=0).T) * np.diff(ts[a:b + 1])))

    def update(self, color: str, stamp_s: float, cands_xy_px: np.ndarray, velocity_px_s: np.ndarray | None,
               px_per_m: float, prefer_xy_px: np.ndarray | None = None, start: bool = True,
               velocity_stamp_s: float | None = None) -> tuple[int | None, str]:
        """This frame's candidates of ``color`` (N, 2), already gated by the prediction, and its UGV's velocity
        in pixels per second (None when not known this frame) as measured at ``velocity_stamp_s`` (its fix's
        time; this frame's by default: a fix arrives late, and a UGV turns in the meantime). Returns the index of the candidate that is the
        label (a confirmed track's; of several, the nearest ``prefer_xy_px``), or None and why: ``unconfirmed``
        (its track's UGV has not moved enough yet to tell), ``moved_unlike_ugv`` (every track was refuted),
        ``no_track`` (candidates, none on a track, and ``start`` False). New tracks start only when ``start``."""
        cfg = self.cfg
        c = self._colors.setdefault(color, _Color())
        if velocity_px_s is not None:
            vs = stamp_s if velocity_stamp_s is None else velocity_stamp_s
            c.velocity = [(s, vv) for s, vv in c.velocity if s != vs and stamp_s - s <= cfg.window_s + cfg.confirmed_keep_s]
            c.velocity.append((vs, np.asarray(velocity_px_s, float)))
            c.velocity.sort(key=lambda sv: sv[0])
        c.tracks = [t for t in c.tracks
                    if stamp_s - t.seen_s <= (cfg.confirmed_keep_s if t.state == CONFIRMED else cfg.keep_s)]
        cands = np.asarray(cands_xy_px, float).reshape(-1, 2)
        # each track takes the nearest candidate to where it should be now, nearest pairs first
        pairs = []
        for i, t in enumerate(c.tracks):
            moved = self._expected(c, t.seen_s, stamp_s, hold=True)
            unseen_s = stamp_s - t.seen_s
            if moved is None:
                moved, slack = np.zeros(2), cfg.unknown_speed_m_s
            else:
                slack = cfg.speed_slack_m_s
            reach = (cfg.reach_m + slack * unseen_s) * px_per_m
            d = np.hypot(*(cands - (t.last_xy + moved)).T) if len(cands) else np.zeros(0)
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
        """A track's state after its newest point: its displacement against its UGV's up to the newest velocity
        sample (the track's place then interpolated between frames), over the shortest span back in which the
        UGV covered ``check_min_m``. A confirmed track is refuted only by ``refute_after`` failed checks in a
        row (one frame's blob cut by a passing walker is not a lie)."""
        cfg = self.cfg
        if not c.velocity:
            return t.state
        ts = np.array([p[0] for p in t.points])
        t1 = min(ts[-1], c.velocity[-1][0])
        if t1 <= ts[0]:
            return t.state
        xs, ys = np.array([p[1] for p in t.points]), np.array([p[2] for p in t.points])
        x1, y1 = float(np.interp(t1, ts, xs)), float(np.interp(t1, ts, ys))
        for k in range(int(np.searchsorted(ts, t1, "left")) - 1, -1, -1):
            expected = self._expected(c, ts[k], t1)
            if expected is None:
                return t.state                  # the UGV's velocity is not known over any longer span either
            e = float(np.hypot(*expected))
            if e >= cfg.check_min_m * px_per_m:
                x0, y0 = xs[k], ys[k]
                break
        else:
            return t.state                      # the UGV has not moved enough to tell: as it was
        if self._unsure(c, ts[k], t1) > cfg.unsure_fraction * e:
            return t.state                      # it turned between fixes: no telling where it was meanwhile
        err = float(np.hypot(x1 - x0 - expected[0], y1 - y0 - expected[1]))
        noise = max(cfg.noise_min_px, cfg.noise_m * px_per_m)
        if err <= cfg.agree_fraction * e + noise:
            t.failed = 0
            return CONFIRMED
        t.failed += 1
        return REFUTED if t.state != CONFIRMED or t.failed >= cfg.refute_after else CONFIRMED
