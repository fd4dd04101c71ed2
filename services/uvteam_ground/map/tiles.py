"""Offline basemaps for the live map: an XYZ tile folder or an MBTiles file, served tile by tile.

    src = open_basemap("maps/sasabe")              # {z}/{x}/{y}.png|.jpg|.webp under this folder
    src = open_basemap("maps/sasabe.mbtiles")      # MBTiles 1.x (raster: png, jpg or webp)
    src.tile(17, 23830, 53254) -> bytes | None

Both are Web Mercator (EPSG:3857) tiles, 256 px, y counted from the north (XYZ); MBTiles stores rows
from the south (TMS) and is flipped here. A GeoTIFF is not read: turn it into one of these first,
e.g. ``gdal2tiles.py --xyz -z 12-19 map.tif maps/sasabe`` or ``gdal_translate -of MBTILES map.tif
map.mbtiles && gdaladdo map.mbtiles``.
"""

from __future__ import annotations

import math
import re
import sqlite3
import threading
from dataclasses import dataclass
from pathlib import Path

from uvteam.errors import ConfigError

__all__ = ["TileSource", "XyzFolder", "MBTiles", "open_basemap", "CONTENT_TYPES"]

CONTENT_TYPES = {"png": "image/png", "jpg": "image/jpeg", "webp": "image/webp"}
_EXT = {"png": "png", "jpg": "jpg", "jpeg": "jpg", "webp": "webp"}


@dataclass(frozen=True)
class TileInfo:
    name: str
    fmt: str                                    # png | jpg | webp
    min_zoom: int
    max_zoom: int
    bounds: tuple[float, float, float, float] | None   # west, south, east, north (deg)
    attribution: str = ""


class TileSource:
    info: TileInfo

    def tile(self, z: int, x: int, y: int) -> bytes | None:
        raise NotImplementedError

    def close(self) -> None:
        pass


class XyzFolder(TileSource):
    def __init__(self, path: Path) -> None:
        self.path = path
        zooms = sorted(int(p.name) for p in path.iterdir() if p.is_dir() and re.fullmatch(r"\d{1,2}", p.name))
        if not zooms:
            raise ConfigError(str(path), "--basemap", "no zoom folders ({z}/{x}/{y}.png) in this folder")
        fmt = None
        for z in zooms:
            first = next((f for f in (path / str(z)).glob("*/*.*") if f.suffix[1:].lower() in _EXT), None)
            if first is not None:
                fmt = _EXT[first.suffix[1:].lower()]
                self._suffix = first.suffix
                break
        if fmt is None:
            raise ConfigError(str(path), "--basemap", "no .png, .jpg or .webp tiles under the zoom folders")
        self.info = TileInfo(path.name, fmt, zooms[0], zooms[-1], _xyz_bounds(path / str(zooms[0]), zooms[0]))

    def tile(self, z: int, x: int, y: int) -> bytes | None:
        f = self.path / str(int(z)) / str(int(x)) / f"{int(y)}{self._suffix}"
        try:
            return f.read_bytes()
        except OSError:
            return None


def _tile_lon_deg(x: float, z: int) -> float:
    return x / (1 << z) * 360.0 - 180.0


def _tile_lat_deg(y: float, z: int) -> float:
    return math.degrees(math.atan(math.sinh(math.pi * (1 - 2 * y / (1 << z)))))


def _xyz_bounds(zoom_dir: Path, z: int) -> tuple[float, float, float, float] | None:
    """West, south, east, north of the tiles at one zoom (the folder's lowest: the fewest files), so the
    page asks only for tiles that can be there."""
    xs = [int(p.name) for p in zoom_dir.iterdir() if p.is_dir() and p.name.isdigit()]
    ys = [int(f.stem) for x in xs for f in (zoom_dir / str(x)).iterdir() if f.stem.isdigit()]
    if not xs or not ys:
        return None
    return (_tile_lon_deg(min(xs), z), _tile_lat_deg(max(ys) + 1, z), _tile_lon_deg(max(xs) + 1, z),
            _tile_lat_deg(min(ys), z))


class MBTiles(TileSource):
    def __init__(self, path: Path) -> None:
        self.path = path
        try:
            self._db = sqlite3.connect(f"file:{path}?mode=ro", uri=True, check_same_thread=False)
            meta = dict(self._db.execute("SELECT name, value FROM metadata").fetchall())
            zr = self._db.execute("SELECT MIN(zoom_level), MAX(zoom_level) FROM tiles").fetchone()
        except sqlite3.Error as exc:
            raise ConfigError(str(path), "--basemap", f"not an MBTiles file: {exc}") from None
        self._lock = threading.Lock()
        fmt = _EXT.get(str(meta.get("format", "png")).lower())
        if fmt is None:
            raise ConfigError(str(path), "metadata.format",
                              f"raster tiles (png, jpg, webp) only, got {meta.get('format')!r}")
        if zr is None or zr[0] is None:
            raise ConfigError(str(path), "tiles", "the file holds no tiles")
        bounds = None
        if "bounds" in meta:
            try:
                w, s, e, n = (float(v) for v in str(meta["bounds"]).split(","))
                bounds = (w, s, e, n)
            except ValueError:
                bounds = None
        self.info = TileInfo(str(meta.get("name", path.stem)), fmt, int(meta.get("minzoom", zr[0])),
                             int(meta.get("maxzoom", zr[1])), bounds, str(meta.get("attribution", "")))

    def tile(self, z: int, x: int, y: int) -> bytes | None:
        row = (1 << int(z)) - 1 - int(y)              # TMS rows count from the south
        with self._lock:
            r = self._db.execute("SELECT tile_data FROM tiles WHERE zoom_level=? AND tile_column=? AND tile_row=?",
                                 (int(z), int(x), row)).fetchone()
        return bytes(r[0]) if r else None

    def close(self) -> None:
        self._db.close()


def open_basemap(path: str | Path) -> TileSource:
    p = Path(path).expanduser()
    if p.is_dir():
        return XyzFolder(p)
    if not p.is_file():
        raise ConfigError(str(p), "--basemap", "no such file or folder")
    if p.suffix.lower() in (".tif", ".tiff"):
        raise ConfigError(str(p), "--basemap", "GeoTIFF is not served directly: make XYZ tiles "
                          "(gdal2tiles.py --xyz) or MBTiles (gdal_translate -of MBTILES) from it")
    with open(p, "rb") as fh:
        if fh.read(16) != b"SQLite format 3\x00":
            raise ConfigError(str(p), "--basemap", "expected an XYZ tile folder or an MBTiles (SQLite) file")
    return MBTiles(p)
