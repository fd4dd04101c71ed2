"""uvteam core."""
