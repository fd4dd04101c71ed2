"""The bridge's file writing: atomic replacement that leaves the file readable, and a failing output
that does not stop the loop."""

import os
import stat

import pytest

from uvteam_ground import bridge


@pytest.mark.parametrize("old_mode, want_mode", [
    (None, 0o644),      # a new file: readable by a web server, not 0600 as mkstemp makes it
    (0o640, 0o640),     # an existing file keeps the mode its owner gave it
])
def test_write_atomic_mode(tmp_path, old_mode, want_mode):
    path = tmp_path / "crowds.geojson"
    if old_mode is not None:
        path.write_text("old")
        os.chmod(path, old_mode)
    bridge.write_atomic(path, b'{"type":"FeatureCollection","features":[]}')
    assert path.read_bytes().startswith(b'{"type"')
    assert stat.S_IMODE(path.stat().st_mode) == want_mode
    assert [p.name for p in tmp_path.iterdir()] == ["crowds.geojson"]      # no temporary file left


def test_write_atomic_leaves_no_temporary_on_failure(tmp_path):
    path = tmp_path / "missing-dir" / "x.kml"
    with pytest.raises(OSError):
        bridge.write_atomic(path, b"x")
    assert list(tmp_path.iterdir()) == []


def test_guarded_logs_an_output_failure_and_goes_on(caplog):
    def write():
        raise OSError(28, "No space left on device")

    bridge._last_io_error.clear()
    bridge._guarded(write)
    bridge._guarded(write)                        # rate-limited: logged once
    assert [r.message for r in caplog.records if "output failed" in r.message] == \
        ["output failed in write: [Errno 28] No space left on device"]


def test_geojson_file_drops_crowds_of_a_quiet_team(tmp_path):
    import json

    from uvteam.messages import Crowd, Crowds

    path = tmp_path / "c.geojson"
    b = bridge.Bridge(bridge.parse_args(["--team", "t", "--geojson", str(path)]), "t")
    t0 = 1_790_000_000.0
    b.on_crowds(Crowds("loc1", "uav1", t0, "exact", (), (), (Crowd(1, 31.0, -111.0, (), (), 0.0, 0.0, 1.0, "exact", 0),)))
    b.tick(100.0, t0 + 0.1)
    assert [f["properties"]["kind"] for f in json.loads(path.read_text())["features"]] == ["crowd", "crowd_r95"]
    b.tick(101.0, t0 + 4.0)                       # within the default max age (5 x 1 s): unchanged
    assert len(json.loads(path.read_text())["features"]) == 2
    b.tick(102.0, t0 + 6.0)                       # no message since: the crowd has aged out of the file
    assert json.loads(path.read_text())["features"] == []
    b.close(t0 + 6.0)
