"""``python -m warehouse_phys.evaluate``: runs :mod:`warehouse_phys.apps.evaluate`."""

import sys

from warehouse_phys.apps import evaluate as _evaluate

if __name__ == "__main__":
    sys.exit(_evaluate.main())
else:
    sys.modules[__name__] = _evaluate
