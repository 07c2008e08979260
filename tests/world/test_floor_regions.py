"""label_regions numbers a floor's regions as scipy.ndimage.label does, on every mask."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from warehouse_phys.world.floor_regions import label_regions


@given(st.integers(1, 24), st.integers(1, 24), st.floats(0, 1), st.integers(0, 2**32 - 1))
def test_regions_are_numbered_as_scipys_label_numbers_them(rows, cols, shelves, seed):
    from scipy import ndimage

    free = np.random.default_rng(seed).random((rows, cols)) >= shelves
    regions, count = label_regions(free)
    expected, expected_count = ndimage.label(free)
    assert count == expected_count
    assert regions.dtype == expected.dtype
    np.testing.assert_array_equal(regions, expected)


def test_regions_that_wind_and_meet_late_are_numbered_as_scipys_label_numbers_them():
    from scipy import ndimage

    serpentine = np.zeros((65, 65), dtype=bool)
    serpentine[::2] = True
    serpentine[1::4, -1] = serpentine[3::4, 0] = True
    spiral = np.zeros((65, 65), dtype=bool)
    for k in range(0, 33, 2):  # rings, each open at its top-left corner into the next
        spiral[k, k : 65 - k] = spiral[k : 65 - k, 64 - k] = spiral[64 - k, k : 65 - k] = True
        spiral[k + 2 : 65 - k, k] = True
    combs = np.zeros((65, 65), dtype=bool)
    combs[:, ::2] = True
    combs[-1] = True  # teeth that meet only on the last row
    for free in (serpentine, spiral, ~spiral, combs, combs[::-1], np.eye(65, dtype=bool)):
        regions, count = label_regions(free)
        expected, expected_count = ndimage.label(free)
        assert count == expected_count
        np.testing.assert_array_equal(regions, expected)
    assert label_regions(np.zeros((3, 4), dtype=bool))[1] == 0
