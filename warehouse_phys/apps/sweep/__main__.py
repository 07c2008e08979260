"""``python -m warehouse_phys.apps.sweep``: the same command as
``python -m warehouse_phys.sweep``."""

import sys

from warehouse_phys.apps.sweep import main

if __name__ == "__main__":
    sys.exit(main())
