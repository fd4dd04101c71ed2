"""uvteam ugv --config deploy/vehicles/ugv1.toml"""

from uvteam.service import service_main


def main(argv=None) -> int:
    from .app import run  # noqa: PLC0415

    return service_main(argv, "uvteam ugv", "UGV service: autopilot -> fix and plan; crowds -> planner -> "
                        "waypoints to the autopilot.", "ugv", run)


if __name__ == "__main__":
    raise SystemExit(main())
