"""``python -m warehouse_phys.simulate``: runs :mod:`warehouse_phys.apps.simulate`.

Imported (not run) this module is that module itself, as the old flat layout had it.
"""

import sys

from warehouse_phys._starting import command_interrupts

with command_interrupts(__name__ == "__main__"):  # Ctrl-C while importing: one line
    from warehouse_phys.apps import simulate as _simulate

if __name__ == "__main__":
    sys.exit(_simulate.main())
else:
    sys.modules[__name__] = _simulate
