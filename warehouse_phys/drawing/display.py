"""pygame and the display: pygame imported only when a picture is first drawn, and a
window refused where nobody could see it (with how to get a display).
"""

from __future__ import annotations

import os
import sys
from types import ModuleType


def import_pygame() -> ModuleType:
    """Import pygame (the ``pygame-ce`` distribution) quietly, or say how to install it."""
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    try:
        import pygame
    except ImportError as exc:  # pragma: no cover - pygame-ce is a runtime dependency
        raise ImportError(
            "rendering needs pygame; install it with `pip install pygame-ce`"
        ) from exc
    return pygame


class NoDisplayError(RuntimeError):
    """There is no display to open a window on; the message says how to get one."""


#: SDL's video drivers that draw nowhere a person can see.
_INVISIBLE_DRIVERS = ("offscreen", "dummy", "evdev")
_NO_DISPLAY_HELP = (
    "run it in a desktop session, forward one with `ssh -X`, or start a virtual one "
    "with `xvfb-run`; rgb_array rendering needs no display"
)


def check_display(pg: ModuleType | None = None) -> None:
    """Refuse to open a window that nobody could see.

    With no ``DISPLAY`` or ``WAYLAND_DISPLAY`` on Linux and the BSDs, SDL falls
    back to its off-screen driver and a window would silently go nowhere. Given
    ``pg`` (pygame with its display initialised), the driver SDL picked is
    checked too. Setting ``SDL_VIDEODRIVER`` (``dummy`` in tests, say) is taken
    as the user's choice and always allowed.

    Raises:
        NoDisplayError: saying there is no display and how to get one.
    """
    if os.environ.get("SDL_VIDEODRIVER"):
        return
    if sys.platform.startswith(("linux", "freebsd", "openbsd", "netbsd")) and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    ):
        raise NoDisplayError(
            f"cannot open a window: there is no display (DISPLAY and WAYLAND_DISPLAY are "
            f"unset); {_NO_DISPLAY_HELP}"
        )
    if pg is not None and pg.display.get_init():
        driver = pg.display.get_driver()
        if driver in _INVISIBLE_DRIVERS:
            raise NoDisplayError(
                f"cannot open a window: SDL found no display and chose its {driver!r} "
                f"driver, which shows nothing; {_NO_DISPLAY_HELP}"
            )
