"""uvteam localizer --config deploy/vehicles/localizer.toml"""

from uvteam.service import service_main


def main(argv=None) -> int:
    from .app import run  # noqa: PLC0415

    return service_main(argv, "uvteam localizer", "Localizer: UAV detections + UGV fixes and plans -> "
                        "geolocated crowds published to the team.", "localizer", run)


if __name__ == "__main__":
    raise SystemExit(main())
