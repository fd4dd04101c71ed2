"""The localizer step as it was before it was made faster (commit 4d30179): frozen copies of
``uvteam.localizer``, ``homography``, ``assignment`` and ``pose``, for :mod:`uvteam_ground.bench_localize`
only (it times the product against this and checks both give the same results). Never imported by the
product; never edited (a change here would move the yardstick)."""
