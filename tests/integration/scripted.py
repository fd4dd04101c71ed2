"""Running the loopback team while a script acts on it (kills, restarts, garbage) from a thread of its own."""

import threading

from uvteam_ground.demo import run_demo


def run_scripted(team, stop, script, holder: dict, view_path):
    """The demo run with ``script`` on a thread; the probe bus the script opens (``holder["probe"]``) closed after."""
    th = threading.Thread(target=script, daemon=True)
    th.start()
    try:
        with open(view_path, "w") as view:
            return run_demo(team, stop, live=False, out=view)
    finally:
        th.join(timeout=5)
        if "probe" in holder:
            holder["probe"].close()
