"""uvteam uav --config deploy/vehicles/uav1.toml"""

from uvteam.service import service_main


def main(argv=None) -> int:
    from .app import run  # noqa: PLC0415

    return service_main(argv, "uvteam uav", "UAV service: camera -> detector -> detections; autopilot -> fix.",
                        "uav", run)


if __name__ == "__main__":
    raise SystemExit(main())
