"""uvteam sim --scenario FILE --uav ID:PORT:SYSID --ugv ID:PORT:SYSID ..."""


def main(argv=None) -> int:
    from .app import main as app_main  # noqa: PLC0415

    return app_main(argv)


if __name__ == "__main__":
    raise SystemExit(main())
