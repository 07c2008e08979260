"""The start-kit entry's settings: what the kit does not tell the entry's components,
they read from environment variables (the kit starts them in its own process, with no
arguments of theirs), each with its default in :data:`SETTINGS`; the entry's command
(:mod:`warehouse_phys.apps.startkit`) checks them before the kit runs, and
:mod:`~warehouse_phys.lorr.startkit.adapters` reads them in the kit."""

from __future__ import annotations

import math
import os
from typing import Any

from warehouse_phys.planners.named import guidance_from_json

__all__ = ["ROUND_SHARE", "SETTINGS", "entry_guidance", "round_share", "setting", "shown"]

#: The share of the kit's ``time_limit`` a round (the scheduler and the planner together)
#: aims at by default: the rest is the answers' way back into the kit, and the machine's
#: load. ``WAREHOUSE_PHYS_ROUND_SHARE`` sets another (:func:`round_share`).
ROUND_SHARE = 0.6

#: The environment variables the components read (see the module), with their defaults.
SETTINGS = {
    "WAREHOUSE_PHYS_AGENT_SIZE": "1",
    "WAREHOUSE_PHYS_PLANNER": "guided-ops-repair",
    "WAREHOUSE_PHYS_GUIDANCE": "{}",
    "WAREHOUSE_PHYS_SCHEDULER": "assignment",
    "WAREHOUSE_PHYS_ROUND_SHARE": str(ROUND_SHARE),
}


def setting(name: str) -> str:
    """The component setting ``name`` (a key of :data:`SETTINGS`) from the environment."""
    return os.environ.get(name, SETTINGS[name])


def shown(name: str, value: str) -> str:
    """``NAME=value`` as an error line shows a setting: the value as given, or quoted (as
    Python writes a string) where it holds a line break or another character that does
    not print, so that the message stays one line."""
    return f"{name}={value if value.isprintable() else repr(value)}"


def round_share() -> float | None:
    """The share of the kit's ``time_limit`` the planner's round aims at, from
    ``WAREHOUSE_PHYS_ROUND_SHARE``: a number above 0 (:data:`ROUND_SHARE` by default), or
    ``none`` for no bound, where the entry plans as the package's simulation of it does
    (the same plan for the same seed, whatever the machine's load; late where the machine
    is slow, which the kit then counts).

    Raises:
        ValueError: naming the variable, for anything else.
    """
    text = setting("WAREHOUSE_PHYS_ROUND_SHARE")
    if text.strip().lower() == "none":
        return None
    try:
        share = float(text)
    except ValueError:
        share = math.nan
    if not share > 0 or math.isinf(share):
        raise ValueError(f"{shown('WAREHOUSE_PHYS_ROUND_SHARE', text)}: a share above 0, or none")
    return share


def entry_guidance() -> dict[str, Any]:
    """The planner's fields that ``WAREHOUSE_PHYS_GUIDANCE`` sets (a JSON object).

    Raises:
        ValueError: naming the variable, for text that is not a JSON object.
    """
    text = setting("WAREHOUSE_PHYS_GUIDANCE")
    try:
        return guidance_from_json(text)
    except ValueError as error:
        raise ValueError(f"{shown('WAREHOUSE_PHYS_GUIDANCE', text)}: {error}") from None
