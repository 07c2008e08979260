"""What every figure shares: the rolling mean."""

import numpy as np
import pytest

from warehouse_phys.viz.figures import rolling_mean


def test_rolling_mean_averages_the_last_window_values():
    values = np.array([4, 2, 6, 8, 0])
    assert rolling_mean(values, 2).tolist() == [4, 3, 4, 7, 4]
    assert rolling_mean(values, 1).tolist() == values.tolist()
    assert rolling_mean(values, 10).tolist() == [4, 3, 4, 5, 4]
    with pytest.raises(ValueError, match="window must be at least 1"):
        rolling_mean(values, 0)
