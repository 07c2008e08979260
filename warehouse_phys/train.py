"""``python -m warehouse_phys.train``: the command line of the tabular Q-learning trainer.

The trainer is not part of this version yet. Until it is, the command says so
and exits with status 1, so that scripts and CI cannot mistake it for a run.
"""

from __future__ import annotations

import sys

NOT_AVAILABLE = (
    "warehouse_phys.train: the Q-learning trainer is not available in this version yet. "
    'The environment is: `import warehouse_phys` then `gym.make("warehouse-robot-v0")` '
    "(see README.md)."
)


def main(argv: list[str] | None = None) -> int:
    """Report that training is not available; returns the exit status (1)."""
    print(NOT_AVAILABLE, file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main())
