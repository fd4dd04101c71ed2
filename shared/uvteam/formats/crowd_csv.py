"""CSV of crowds with their MGRS reference: for spreadsheets and any GIS that reads delimited text.

    stamp_s,crowd_id,lat_deg,lon_deg,mgrs,radius95_m,quality,v_east_m_s,v_north_m_s,unseen_s

One row per crowd per frame it was reported in (RFC 4180: comma separated, CRLF line ends as the csv
module writes them, a header row). stamp_s is the frame's capture time in UNIX seconds (3 decimals),
lat/lon WGS84 degrees (7 decimals), mgrs at 1 m (empty beyond the UTM part, |lat| past -80/84),
radius95_m, velocities and unseen_s (0: seen in that frame; else seconds unseen, the position predicted)
to 0.01.
"""

from __future__ import annotations

import csv
import io
from typing import Iterable

from ._geometry import mgrs_or_empty
from .picture import CrowdSeen

__all__ = ["COLUMNS", "HEADER", "rows"]

COLUMNS = ("stamp_s", "crowd_id", "lat_deg", "lon_deg", "mgrs", "radius95_m", "quality", "v_east_m_s", "v_north_m_s", "unseen_s")


def _text(rows_: Iterable[tuple]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf)
    for r in rows_:
        w.writerow(r)
    return buf.getvalue()


HEADER = _text([COLUMNS])


def rows(crowds: Iterable[CrowdSeen]) -> str:
    """The rows (no header) for these crowds, in the order given."""
    return _text((f"{c.stamp_s:.3f}", c.crowd.crowd_id, f"{c.crowd.lat_deg:.7f}", f"{c.crowd.lon_deg:.7f}",
                  mgrs_or_empty(c.crowd.lat_deg, c.crowd.lon_deg), f"{c.crowd.radius95_m:.2f}", c.crowd.quality,
                  f"{c.crowd.v_east_m_s:.2f}", f"{c.crowd.v_north_m_s:.2f}", f"{c.crowd.unseen_s:.2f}") for c in crowds)
