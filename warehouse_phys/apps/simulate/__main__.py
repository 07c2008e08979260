"""``python -m warehouse_phys.apps.simulate``: the same command as
``python -m warehouse_phys.simulate``."""

import sys

from warehouse_phys.apps.simulate import main

if __name__ == "__main__":
    sys.exit(main())
