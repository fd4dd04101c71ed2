"""Crowd tracks on the ground: stable ids and velocities for the localizer's per-frame estimates.

A pure state machine in the style of norfair's ``Tracker.update``: gated nearest-neighbour association
(Hungarian on ground distance), an alpha-beta filter for position and velocity, tracks that miss
``max_misses`` consecutive updates are dropped. Each track keeps a short trail of the estimates it was
given (``trail_s``; unfiltered, so a frame in which two parts were seen as one leaves no mark on the
others), from which :mod:`uvteam.crowds` tells two crowds from two parts of one. No I/O, time passed in.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .assignment import assign_optimal

__all__ = ["CrowdTrack", "CrowdTracker"]


@dataclass(frozen=True, slots=True)
class CrowdTrack:
    track_id: int
    east_m: float
    north_m: float
    v_east_m_s: float
    v_north_m_s: float
    stamp_s: float
    hits: int
    misses: int
    trail: tuple[tuple[float, float, float], ...] = ()   # (stamp s, east m, north m) of recent estimates, oldest first
    first_s: float = float("nan")                         # stamp of its first estimate

    def shifted(self, d_east_m: float, d_north_m: float) -> "CrowdTrack":
        """The track moved by (``d_east_m``, ``d_north_m``), its trail with it (a new frame of placement)."""
        return replace(self, east_m=self.east_m + d_east_m, north_m=self.north_m + d_north_m,
                       trail=tuple((t, e + d_east_m, n + d_north_m) for t, e, n in self.trail))

    def predicted(self, stamp_s: float) -> tuple[float, float]:
        """(east m, north m) at ``stamp_s`` at the track's velocity."""
        dt = stamp_s - self.stamp_s
        return self.east_m + self.v_east_m_s * dt, self.north_m + self.v_north_m_s * dt


@dataclass(frozen=True, slots=True)
class CrowdTracker:
    gate_m: float = 4.0                 # a crowd moves < 0.5 m between frames; a jump is a new track
    alpha: float = 0.4                  # at 10 Hz with ~0.5 m measurement noise: the velocity gain beta/dt
    beta: float = 0.05                  # (0.5 per m of residual) keeps the velocity within ~0.3 m/s
    max_misses: int = 10
    trail_s: float = 10.0               # what crowds.py reads from it: the parts' drift (3 s) and the scatter (8 s)
    tracks: tuple[CrowdTrack, ...] = ()
    next_id: int = 1

    def update(self, en_m: np.ndarray, stamp_s: float) -> tuple["CrowdTracker", list[CrowdTrack]]:
        """Associate this frame's estimates (N, 2); returns the new tracker and one track per estimate."""
        en = np.asarray(en_m, float).reshape(-1, 2)
        pred = np.array([t.predicted(stamp_s) for t in self.tracks]).reshape(-1, 2)
        asg = assign_optimal(pred, en, self.gate_m) if len(pred) and len(en) else None
        pairs = asg.blob_of_landmark if asg else {}
        out: list[CrowdTrack | None] = [None] * len(en)
        kept: list[CrowdTrack] = []
        for i, t in enumerate(self.tracks):
            if i in pairs:
                j = pairs[i]
                dt = max(stamp_s - t.stamp_s, 1e-3)
                r = en[j] - pred[i]
                p = pred[i] + self.alpha * r
                v = np.array([t.v_east_m_s, t.v_north_m_s]) + (self.beta / dt) * r
                trail = tuple(s for s in t.trail if s[0] >= stamp_s - self.trail_s) + ((stamp_s, float(en[j, 0]), float(en[j, 1])),)
                nt = replace(t, east_m=float(p[0]), north_m=float(p[1]), v_east_m_s=float(v[0]),
                             v_north_m_s=float(v[1]), stamp_s=stamp_s, hits=t.hits + 1, misses=0, trail=trail)
                kept.append(nt)
                out[j] = nt
            elif t.misses + 1 <= self.max_misses:
                kept.append(replace(t, misses=t.misses + 1))
        nid = self.next_id
        for j in range(len(en)):
            if out[j] is None:
                nt = CrowdTrack(nid, float(en[j, 0]), float(en[j, 1]), 0.0, 0.0, stamp_s, 1, 0,
                                ((stamp_s, float(en[j, 0]), float(en[j, 1])),), stamp_s)
                nid += 1
                kept.append(nt)
                out[j] = nt
        return replace(self, tracks=tuple(kept), next_id=nid), out  # type: ignore[return-value]
