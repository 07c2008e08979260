"""``python -m warehouse_phys.train``: runs :mod:`warehouse_phys.apps.train`.

Imported (not run) this module is that module itself, as the old flat layout had it.
"""

import sys

from warehouse_phys._starting import command_interrupts

with command_interrupts(__name__ == "__main__"):  # Ctrl-C while importing: one line
    from warehouse_phys.apps import train as _train

if __name__ == "__main__":
    sys.exit(_train.main())
else:
    sys.modules[__name__] = _train
