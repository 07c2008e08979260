"""``python -m warehouse_phys.startkit``: runs :mod:`warehouse_phys.apps.startkit`.

Imported (not run) this module is that module itself, as :mod:`warehouse_phys.simulate` is.
"""

import sys

from warehouse_phys._starting import command_interrupts

with command_interrupts(__name__ == "__main__"):  # Ctrl-C while importing: one line
    from warehouse_phys.apps import startkit as _startkit

if __name__ == "__main__":
    sys.exit(_startkit.main())
else:
    sys.modules[__name__] = _startkit
