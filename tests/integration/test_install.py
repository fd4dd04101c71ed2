"""A plain `pip install` of the wheel into a fresh venv works from any folder: `uvteam --version`, and
`uvteam demo --duration 5 --frames sensor` run from a temporary folder (the demo scenario and the
map's page are package data), with every service exiting 0 and no warning in any log."""

import os
import time
import subprocess
import sys
import urllib.request
import venv
from pathlib import Path

import pytest

pytestmark = [pytest.mark.integration, pytest.mark.slow]
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    d = tmp_path_factory.mktemp("install")
    r = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(d / "dist"), str(ROOT)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    (wheel,) = (d / "dist").glob("uvteam-*.whl")
    venv.create(d / "venv", with_pip=True)
    py = d / "venv" / "bin" / "python"
    r = subprocess.run([str(py), "-m", "pip", "install", "-q", str(wheel)], capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    return d, d / "venv" / "bin" / "uvteam", wheel


def test_the_wheel_ships_the_license_the_demo_scenario_and_the_map(installed):
    import zipfile

    names = zipfile.ZipFile(installed[2]).namelist()
    assert any(n.endswith("licenses/LICENSE") for n in names)
    for need in ("uvteam_ground/data/demo.toml", "uvteam_ground/map/static/index.html",
                 "uvteam_ground/map/static/vendor/leaflet/leaflet.js"):
        assert need in names, need
    assert not any(n.startswith("tests/") for n in names)


def test_version(installed):
    r = subprocess.run([str(installed[1]), "--version"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stdout.startswith("uvteam 0.1.0 (Python ")


def test_demo_from_any_folder(installed, tmp_path):
    d, uvteam, _ = installed
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    demo = subprocess.Popen([str(uvteam), "demo", "--duration", "5", "--frames", "sensor", "--map-http", "127.0.0.1:0",
                             "--workdir", str(tmp_path / "work")], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        head = [demo.stdout.readline() for _ in range(4)]
        assert head[1].strip().startswith("configs and logs:"), head
        map_url = head[3].split("open ", 1)[1].split()[0]
        # the map's page and scripts come from the installed package
        for _ in range(100):
            try:
                page = urllib.request.urlopen(map_url, timeout=2).read().decode()
                break
            except OSError:
                time.sleep(0.2)
        assert "static/map.js" in page
        assert urllib.request.urlopen(map_url + "static/vendor/leaflet/leaflet.js", timeout=5).status == 200
        out, _ = demo.communicate(timeout=120)
    finally:
        if demo.poll() is None:
            demo.kill()
            demo.wait()
    assert demo.returncode == 0, "".join(head) + out
    assert "frames scored" in out and "crowd 1 " in out
    logs = {p.name: p.read_text() for p in (tmp_path / "work" / "logs").glob("*.log")}
    assert {"router.log", "localizer.log", "uav1.log", "ugv1.log", "sim.log", "map.log"} <= set(logs)
    for name, text in logs.items():      # a clean run and a clean stop: nothing worth a warning
        bad = [line for line in text.splitlines() if " WARNING " in line or " ERROR " in line or "Traceback" in line]
        assert not bad, (name, bad[:3])
