"""UGV station planning: keep the UGVs on a ring around the predicted crowd position. Pure.

Stations are ``n`` points evenly spaced on a ring of ``radius_m`` around where the crowd will be
(its position plus velocity times the lead time), so four or more are never collinear, and the ring
is shrunk to fit inside the UAV camera's ground footprint (with a margin) so every UGV stays in view
as a landmark. UGVs are matched to stations by the optimal assignment on distance, which every UGV
service computes identically from the same fixes, so each can plan for itself without a coordinator.
The ring's phase is chosen so that the assignment moves the team least.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

__all__ = ["StationPlan", "plan_stations"]


@dataclass(frozen=True, slots=True)
class StationPlan:
    ugv: str
    stamp_s: np.ndarray     # (k,) times of the waypoints
    en_m: np.ndarray        # (k, 2) waypoints
    speed_m_s: np.ndarray   # (k,) speed on the leg that ends at each waypoint


def plan_stations(crowd_en_m, crowd_v_m_s, ugv_en_m: dict[str, np.ndarray], now_s: float, *,
                  radius_m: float, view_half_m: tuple[float, float] | None = None,
                  horizon_s: float = 3.0, step_s: float = 1.0, max_speed_m_s: float = 4.0,
                  n_phases: int = 12) -> dict[str, StationPlan]:
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
    best = None
    for phase in np.linspace(0, 2 * np.pi / n, n_phases, endpoint=False):
        ang = base + phase
        st = c + r * np.column_stack([np.sin(ang), np.cos(ang)])
        d = np.sqrt(((pos[:, None] - st[None]) ** 2).sum(-1))
        ri, ci = linear_sum_assignment(d)
        cost = d[ri, ci].sum()
        if best is None or cost < best[0] - 1e-9:
            best = (cost, ang[ci])
    ang_of = best[1]
    k = max(int(round(horizon_s / step_s)), 1)
    ts = now_s + step_s * np.arange(1, k + 1)
    out = {}
    for i, u in enumerate(ids):
        off = r * np.array([np.sin(ang_of[i]), np.cos(ang_of[i])])
        wps = c + off + np.outer(ts - now_s, v)
        prev = np.vstack([pos[i], wps[:-1]])
        leg = np.sqrt(((wps - prev) ** 2).sum(1))
        speed = np.minimum(leg / step_s, max_speed_m_s)
        # a leg that needs more than the speed limit arrives later: times follow the speeds
        dt = np.where(speed > 0, leg / np.maximum(speed, 1e-9), step_s)
        out[u] = StationPlan(u, now_s + np.cumsum(dt), wps, np.maximum(speed, 0.1))
    return out
