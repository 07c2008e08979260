"""Test-wide settings: no window, no sound, no GUI backend, reproducible hypothesis runs."""

import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

# Set before anything imports pygame or matplotlib, and inherited by subprocesses.
os.environ["SDL_VIDEODRIVER"] = "dummy"
os.environ["SDL_AUDIODRIVER"] = "dummy"
os.environ["MPLBACKEND"] = "Agg"
os.environ["PYGAME_HIDE_SUPPORT_PROMPT"] = "1"

import pytest
from hypothesis import settings

# The suite starts some 160 Python processes that import the package. Where bytecode
# caching is off (PYTHONDONTWRITEBYTECODE, which many containers set), each of them
# compiles every module it imports again (0.2 s of CPU for `simulate`'s, here), and
# every xdist worker rewrites every test module's asserts again. The suite turns the
# caching back on for itself and its subprocesses; the caches go to the __pycache__
# folders, which git ignores.
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
sys.dont_write_bytecode = False

# CI runs the same examples every time; locally hypothesis explores as usual.
settings.register_profile("ci", derandomize=True, database=None, deadline=None)
settings.register_profile("dev", deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else "dev")


ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(autouse=True, scope="session")
def sb3_logs_in_pytests_temporary_folder(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Stable-Baselines3 makes a log folder in the system's temporary folder at every
    ``learn`` (``SB3-<time>``) unless ``SB3_LOGDIR`` names one: keep them in pytest's
    (which it prunes), for the tests and the notebooks' kernels alike."""
    os.environ.setdefault("SB3_LOGDIR", str(tmp_path_factory.mktemp("sb3_logs")))


@pytest.fixture
def run_python() -> Callable[..., str]:
    """Run a Python snippet in a fresh interpreter from the repository root; return its stdout.

    A fresh process shows what a user's script sees: nothing imported yet,
    nothing left over from other tests.
    """

    def run(script: str, **kwargs: object) -> str:
        kwargs.setdefault("cwd", ROOT)
        result = subprocess.run(
            [sys.executable, "-c", script], capture_output=True, text=True, **kwargs
        )
        assert result.returncode == 0, result.stderr
        return result.stdout

    return run
