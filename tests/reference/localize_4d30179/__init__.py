"""The localizer step as it was before it was made faster (commit 4d30179): frozen copies of
``uvteam.localizer``, ``homography``, ``assignment`` and ``pose``. Test code, not shipped: the yardstick of
tests/unit/test_localizer_same_as_reference.py and, in a source checkout, of ``uvteam bench localize``
(it times the product against this and checks both give the same results). Never edited: a change here
would move the yardstick."""
