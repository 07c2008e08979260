"""``python -m warehouse_phys.evaluate``: runs :mod:`warehouse_phys.apps.evaluate`.

Imported (not run) this module is that module itself, as :mod:`warehouse_phys.simulate` is.
"""

import sys

from warehouse_phys._starting import command_interrupts

with command_interrupts(__name__ == "__main__"):  # Ctrl-C while importing: one line
    from warehouse_phys.apps import evaluate as _evaluate

if __name__ == "__main__":
    sys.exit(_evaluate.main())
else:
    sys.modules[__name__] = _evaluate
