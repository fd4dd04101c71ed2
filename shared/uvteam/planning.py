"""UGV station planning: keep the UGVs on a ring around the predicted crowd position. Pure.

Stations are ``n`` points evenly spaced on a ring of ``radius_m`` around where the crowd will be
(its position plus velocity times the lead time), so four or more are never collinear, and the ring
is shrunk to fit inside the UAV camera's ground footprint (with a margin) so every UGV stays in view
as a landmark. UGVs are matched to stations keeping their cyclic order around the crowd (the
assignment moving the team least among those that keep the order): a UGV is never sent across the
ring, so no path runs through the crowd, where a UGV's motion blob would merge with the crowd's. Every
UGV service computes the same plan from the same fixes, so each can plan for itself without a
coordinator. For a moving crowd the ring is oriented by its direction of travel (stations symmetric
about it); for a still one the phase is chosen with the assignment. When a UGV's straight way to its station,
seen from the crowd (moving with it), would still pass within ``clearance`` x radius of the crowd (the team
bunched on one side), it goes round on the ring instead, in arcs of at most 60 degrees that move with the
crowd.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["StationPlan", "plan_stations"]

MOVING_M_S = 0.3   # slower than this, a crowd's direction of travel is not used to place the ring


@dataclass(frozen=True, slots=True)
class StationPlan:
    ugv: str
    stamp_s: np.ndarray     # (k,) times of the waypoints
    en_m: np.ndarray        # (k, 2) waypoints
    speed_m_s: np.ndarray   # (k,) speed on the leg that ends at each waypoint


def plan_stations(crowd_en_m, crowd_v_m_s, ugv_en_m: dict[str, np.ndarray], now_s: float, *,
                  radius_m: float, view_half_m: tuple[float, float] | None = None,
                  horizon_s: float = 3.0, step_s: float = 1.0, max_speed_m_s: float = 4.0,
                  n_phases: int = 12, clearance: float = 0.7) -> dict[str, StationPlan]:
    ids = sorted(ugv_en_m)
    n = len(ids)
    if n == 0:
        return {}
    c = np.asarray(crowd_en_m, float)
    v = np.asarray(crowd_v_m_s, float)
    r = float(radius_m)
    if view_half_m is not None:
        r = min(r, 0.8 * min(view_half_m))
    pos = np.array([ugv_en_m[u] for u in ids], float)
    base = 2 * np.pi * np.arange(n) / n
    order = np.argsort(np.arctan2(pos[:, 0] - c[0], pos[:, 1] - c[1]) % (2 * np.pi), kind="stable")
    best = None
    speed = float(np.hypot(*v))
    if speed > MOVING_M_S:
        # a moving crowd: the ring is set by its direction of travel, stations symmetric about it (none
        # dead ahead). Choosing the phase that moves the team least would ratchet the ring backwards
        # whenever the team lags a crowd faster than the UGVs' station speed, sweeping them behind it.
        phases = [np.arctan2(v[0], v[1]) + np.pi / n]
    else:
        phases = np.linspace(0, 2 * np.pi / n, n_phases, endpoint=False)
    for phase in phases:
        ang = base + phase
        st = c + r * np.column_stack([np.sin(ang), np.cos(ang)])
        d = np.sqrt(((pos[:, None] - st[None]) ** 2).sum(-1))
        for shift in range(n):
            ci = (np.arange(n) + shift) % n            # the k-th UGV by bearing -> station k + shift
            cost = d[order, ci].sum()
            if best is None or cost < best[0] - 1e-9:
                ang_of = np.empty(n)
                ang_of[order] = ang[ci]
                best = (cost, ang_of)
    ang_of = best[1]
    k = max(int(round(horizon_s / step_s)), 1)
    out = {}
    for i, u in enumerate(ids):
        off = r * np.array([np.sin(ang_of[i]), np.cos(ang_of[i])])
        # the way to the station is judged where the crowd is seen from (moving with it): a UGV ahead
        # of a fast crowd is not sent round a ring that the crowd carries away from it
        around = _detour(pos[i] - c, off, r, clearance)
        lead = np.arange(1, len(around) + k + 1) * step_s     # each waypoint one step after the last
        rel = np.vstack([around, np.repeat(off[None], k, 0)])
        wps = c + rel + np.outer(lead, v)
        prev = np.vstack([pos[i], wps[:-1]])
        leg = np.sqrt(((wps - prev) ** 2).sum(1))
        speed = np.minimum(leg / step_s, max_speed_m_s)
        # a leg that needs more than the speed limit arrives later: times follow the speeds
        dt = np.where(speed > 0, leg / np.maximum(speed, 1e-9), step_s)
        out[u] = StationPlan(u, now_s + np.cumsum(dt), wps, np.maximum(speed, 0.1))
    return out


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    t = float(np.clip(np.dot(p - a, ab) / max(float(np.dot(ab, ab)), 1e-12), 0.0, 1.0))
    return float(np.linalg.norm(a + t * ab - p))


def _detour(start: np.ndarray, goal: np.ndarray, r: float, clearance: float) -> np.ndarray:
    """Points on the ring (about the origin, the crowd) from ``start``'s bearing towards ``goal``'s, the
    short way round, or none when the straight way keeps ``clearance`` x ``r`` from the crowd."""
    centre = np.zeros(2)
    if r <= 0 or _segment_distance(centre, start, goal) >= clearance * r:
        return np.empty((0, 2))
    a0 = np.arctan2(*start)
    a1 = np.arctan2(*goal)
    da = (a1 - a0 + np.pi) % (2 * np.pi) - np.pi
    m = int(np.ceil(abs(da) / (np.pi / 3)))
    ang = a0 + da * np.arange(0, m) / m
    return r * np.column_stack([np.sin(ang), np.cos(ang)])
