"""Test-wide settings: no window, no sound, no GUI backend, reproducible hypothesis runs."""

import os

# Set before anything imports pygame or matplotlib, and inherited by subprocesses.
os.environ["SDL_VIDEODRIVER"] = "dummy"
os.environ["SDL_AUDIODRIVER"] = "dummy"
os.environ["MPLBACKEND"] = "Agg"
os.environ["PYGAME_HIDE_SUPPORT_PROMPT"] = "1"

from hypothesis import settings

# CI runs the same examples every time; locally hypothesis explores as usual.
settings.register_profile("ci", derandomize=True, database=None, deadline=None)
settings.register_profile("dev", deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else "dev")
