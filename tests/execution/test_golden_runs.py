"""The executor's disc model (our floors) is bit-identical to the executor before the start
kit's square robots: the recorded golden runs replay to the same digests."""

import pytest

from tests.execution.golden_runs import GOLDEN, RUNS, digest


@pytest.mark.parametrize("name", [run[0] for run in RUNS])
def test_the_disc_model_replays_its_golden_runs_bit_for_bit(name):
    assert digest(name) == GOLDEN[name]
