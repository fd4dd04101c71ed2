"""`uvteam process` on a recorded flight: a video and the UGVs' fixes, as a user with logs has them.

The recording is made from the simulator (rendered frames written to a video file, the UGVs' true
positions written as a fixes CSV with one bad row), processed by the real command, and the crowds it
writes are scored against the crowd's true centroid at each frame's time."""

import csv
import subprocess
import sys

import cv2
import numpy as np
import pytest

from uvteam.io.files import load_scenario
from uvteam_ground.demo import DEFAULT_SCENARIO
from uvteam_sim.render import Renderer
from uvteam_sim.world import SimWorld

pytestmark = pytest.mark.integration
FPS = 10.0


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    d = tmp_path_factory.mktemp("flight")
    sc = load_scenario(DEFAULT_SCENARIO)
    world = SimWorld(sc, 3)
    r = Renderer(world, np.random.default_rng(3))
    video = cv2.VideoWriter(str(d / "flight.avi"), cv2.VideoWriter_fourcc(*"MJPG"), FPS, (1280, 720))
    truth, rows = [], []
    for k in range(50):
        t = k / FPS
        video.write(r.render(world.camera_pose()))
        truth.append(world.truth_crowds()[0][0].copy())
        for i, u in enumerate(f"ugv{j + 1}" for j in range(sc.ugvs.count)):
            lat, lon = world.frame.ground_to_wgs84(*world.ugv_p[i])
            rows.append([f"{t:.2f}", u, f"{float(lat):.8f}", f"{float(lon):.8f}", "0.05", "", "0", "0", "extra"])
        for _ in range(4):
            world.step(0.025)
    video.release()
    with open(d / "fixes.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t_s", "ugv", "lat_deg", "lon_deg", "h_acc_m", "heading_deg", "v_east_m_s", "v_north_m_s", "note"])
        w.writerows(rows[:30] + [["1.00", "ugv1", "not a latitude", "-111.5", "", "", "", "", ""]] + rows[30:])
    colors = ", ".join(f'{c} = "ugv{i + 1}"' for i, c in enumerate(sc.ugvs.colors))
    ugvs = ", ".join(f'"ugv{i + 1}"' for i in range(sc.ugvs.count))
    (d / "team.toml").write_text(f'[vehicle]\nteam = "rec"\nid = "loc1"\nrole = "localizer"\n\n'
                                 f'[uav]\ndetector = "pixels"\nhfov_deg = {sc.camera.hfov_deg}\ncolors = {{ {colors} }}\n\n'
                                 f'[localizer]\nuav = "uav1"\nugvs = [{ugvs}]\n')
    out = d / "out"
    p = subprocess.run([sys.executable, "-m", "uvteam", "process", "--video", str(d / "flight.avi"), "--fixes",
                        str(d / "fixes.csv"), "--config", str(d / "team.toml"), "--altitude-agl-m", str(sc.uav.altitude_agl_m),
                        "--out", str(out)], capture_output=True, text=True, timeout=300)
    return world, truth, out, p


def test_process_puts_the_recorded_crowd_on_the_map(recording):
    world, truth, out, p = recording
    assert p.returncode == 0, p.stderr[-3000:]
    with open(out / "crowds.csv") as f:
        rows = list(csv.DictReader(f))
    frames = {int(r["frame"]) for r in rows}
    assert len(frames) >= 40                                    # the crowd from the first second on
    errs = []
    for r in rows:
        e, n = world.frame.wgs84_to_ground(float(r["lat_deg"]), float(r["lon_deg"]))
        errs.append((float(np.hypot(e - truth[int(r["frame"])][0], n - truth[int(r["frame"])][1])), float(r["radius95_m"])))
    e = np.array(errs)
    assert np.median(e[:, 0]) < 1.5 and e[:, 0].max() < 3.0, e[:, 0]
    assert {r["quality"] for r in rows} <= {"exact", "least_squares", "robust"}


def test_process_writes_valid_geojson_and_reports_bad_rows(recording):
    world, truth, out, p = recording
    import geojson

    fc = geojson.loads((out / "crowds.geojson").read_text())
    assert fc.is_valid and len(fc["features"]) > 40
    assert fc["features"][0]["geometry"]["type"] == "Point"
    assert "fixes.csv:32: lat_deg is not a number" in p.stderr      # line 32: the header is line 1
    assert "Traceback" not in p.stderr


def test_bad_inputs_are_clear_errors(tmp_path, recording):
    world, truth, out, p = recording
    d = out.parent
    (tmp_path / "empty.csv").write_text("t_s,lat_deg\n1,2\n")
    r = subprocess.run([sys.executable, "-m", "uvteam", "process", "--video", str(d / "flight.avi"), "--fixes",
                        str(tmp_path / "empty.csv"), "--config", str(d / "team.toml"), "--altitude-agl-m", "50",
                        "--out", str(tmp_path / "o")], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "the header lacks ugv, lon_deg" in r.stderr and "Traceback" not in r.stderr
