"""A sweep's trials: every combination of the settings, in order, within the limit."""

import pytest

from warehouse_phys import sweep as sweep_cli
from warehouse_phys.apps.cli import UsageError
from warehouse_phys.apps.sweep import trials as sweep_trials


def test_the_grid_of_trials_is_every_combination_in_order():
    argv = ["--env", "grid", "phys", "--layout", "default", "maze", "--seeds", "3-4"]
    argv += ["--alpha", "0.5", "0.9"]
    args = sweep_cli.build_parser().parse_args(argv)
    trials = sweep_trials.trials_from_args(args)
    assert len(trials) == 2 * 2 * 2 * 2
    assert trials[0].name == "grid-default-a0.5-g0.9-e1000-seed3"
    maze = [t for t in trials if t.floor_name == "maze"]
    assert {t.episodes for t in maze} == {5000}  # the preset's own training episodes
    assert len({t.folder for t in trials}) == len(trials)


def test_the_trial_limit_counts_every_axis_and_allows_exactly_the_limit():
    parse = sweep_cli.build_parser().parse_args
    assert sweep_trials.MAX_TRIALS == sweep_trials.MAX_SEEDS  # the most seeds alone still fit
    assert len(sweep_trials.trials_from_args(parse(["--seeds", "0-9999"]))) == 10_000
    with pytest.raises(UsageError, match="ask for 10,002 trials"):
        sweep_trials.settings_from_args(parse(["--seeds", "5001", "--episodes", "10", "20"]))
    with pytest.raises(UsageError, match="ask for 10,100 trials"):
        sweep_trials.settings_from_args(parse(["--env", "grid", "phys", "--seeds", "5050"]))
