"""LoRR 2026's delays: every rule of the model, its statistics, its config's checks, and
the same draws in any process."""

import hashlib
import itertools
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.memory import CAN_MEASURE, resident_bytes
from warehouse_phys.execution.delays import DelayConfig, DelayGenerator
from warehouse_phys.lorr.instances import read_instance

#: The competition's instances beside the repository, absent on a fresh clone.
LORR = Path(__file__).resolve().parents[3] / "shared" / "lorr"


def config(**changes) -> DelayConfig:
    """A bernoulli config with one-tick delays, changed as asked."""
    fields = {"seed": 0, "min_delay": 1, "max_delay": 1, "event_model": "bernoulli",
              "p_delay": 0.1, "duration_model": "uniform"}  # fmt: skip
    return DelayConfig(**{**fields, **changes})


def run(generator: DelayGenerator, ticks: int) -> np.ndarray:
    """The delayed masks of ``ticks`` ticks, ``(ticks, n_robots)``."""
    masks = [generator.next_tick() for _ in range(ticks)]
    return np.array(masks, dtype=bool).reshape(ticks, generator.n_robots)


def new_delays_per_tick(generator: DelayGenerator, ticks: int) -> np.ndarray:
    run(generator, ticks)
    return np.bincount(generator.intervals().start, minlength=ticks)


def masks_from_intervals(generator: DelayGenerator, ticks: int) -> np.ndarray:
    """Which robot is delayed at which tick, rebuilt from the intervals [start, end)."""
    masks = np.zeros((ticks, generator.n_robots), dtype=bool)
    for robot, start, end in zip(*generator.intervals(), strict=True):
        masks[start : min(end, ticks), robot] = True
    return masks


# The rules, one at a time.


def test_lorrs_own_test_a_certain_two_tick_delay_comes_back_every_second_tick():
    # The start kit's tests/delay_generator_test.cpp: pDelay 1, delays of 2 ticks, 1 robot.
    generator = DelayGenerator(config(min_delay=2, max_delay=2, p_delay=1.0), 1)
    delayed = run(generator, 6)
    assert delayed[:, 0].tolist() == [True] * 6
    assert new_delays_per_tick(DelayGenerator(generator.config, 1), 6).tolist() == [1, 0] * 3
    assert generator.intervals_json() == [[[0, 2], [2, 4], [4, 6]]]


def test_p_delay_zero_never_delays_anyone():
    for event_model in ("bernoulli", "poisson"):
        generator = DelayGenerator(config(p_delay=0.0, event_model=event_model), 50)
        assert not run(generator, 200).any()
        assert generator.intervals_json() == [[] for _ in range(50)]
        assert generator.tick == 200


def test_p_delay_one_with_bernoulli_delays_every_available_robot_at_once():
    generator = DelayGenerator(config(min_delay=3, max_delay=5, p_delay=1.0), 40)
    delayed = run(generator, 30)
    assert delayed.all()
    intervals = generator.intervals()
    # Every robot is hit at tick 0 and again at each tick its delay ends, never sooner.
    for robot in range(40):
        mine = intervals.robot == robot
        starts, ends = intervals.start[mine], intervals.end[mine]
        assert starts[0] == 0
        assert (starts[1:] == ends[:-1]).all()


def test_a_delayed_robot_is_not_hit_again_until_its_delay_ends():
    generator = DelayGenerator(config(min_delay=10, max_delay=10, p_delay=1.0), 3)
    run(generator, 10)
    assert generator.remaining.tolist() == [1, 1, 1]  # tick 9: the last of the delay
    assert generator.intervals_json() == [[[0, 10]]] * 3
    assert generator.next_tick().tolist() == [True] * 3  # tick 10: free, and hit again
    assert generator.intervals_json() == [[[0, 10], [10, 20]]] * 3


def test_a_delay_drawn_at_tick_t_holds_its_robot_from_t_for_d_ticks():
    generator = DelayGenerator(config(min_delay=4, max_delay=4, p_delay=0.02), 300)
    delayed = run(generator, 400)
    assert delayed.any()
    assert (delayed == masks_from_intervals(generator, 400)).all()
    intervals = generator.intervals()
    assert (intervals.end - intervals.start == 4).all()
    for robot, start in zip(intervals.robot[:20], intervals.start[:20], strict=True):
        if start > 0 and start + 4 < 400:
            assert delayed[start - 1 : start + 5, robot].tolist()[1:5] == [True] * 4


def test_the_intervals_of_a_long_run_are_every_delay_in_order():
    # Past 1,024 ticks with delays the kept delays are joined into blocks: none is lost.
    generator = DelayGenerator(config(min_delay=1, max_delay=3, p_delay=0.05, seed=9), 20)
    delayed = run(generator, 2500)
    robot, start, _ = generator.intervals()
    assert (delayed == masks_from_intervals(generator, 2500)).all()
    assert (np.lexsort((robot, start)) == np.arange(len(robot))).all()
    assert len(np.unique(start)) > 1024


def test_the_remaining_ticks_count_this_tick_and_are_read_only():
    generator = DelayGenerator(config(min_delay=3, max_delay=3, p_delay=1.0), 2)
    seen = []
    for _ in range(4):
        generator.next_tick()
        seen.append(generator.remaining.tolist())
    assert seen == [[3, 3], [2, 2], [1, 1], [3, 3]]
    with pytest.raises(ValueError, match="read-only"):
        generator.remaining[0] = 0


def test_poisson_draws_at_most_the_available_robots():
    # Rate 5 * 1.0 = 5 a tick, on 5 robots held 100 ticks: all hit at once, then none.
    generator = DelayGenerator(config(event_model="poisson", p_delay=1.0, min_delay=100,
                                      max_delay=100), 5)  # fmt: skip
    counts = new_delays_per_tick(generator, 100)
    assert counts[0] <= 5
    assert counts[1:].sum() <= 5 - counts[0]  # only robots still free can be hit
    for robot in generator.intervals_json():
        assert len(robot) <= 1


def test_the_poisson_rate_counts_the_whole_team_even_its_delayed_robots():
    # 100 robots, 90 of them held for the whole run: the rate stays 100 * 0.02 = 2 a tick.
    generator = DelayGenerator(config(event_model="poisson", p_delay=0.02), 100)
    generator._remaining[:90] = 10**6  # held, as if by a long delay
    counts = new_delays_per_tick(generator, 4000)
    assert abs(counts.mean() - 2.0) < 5 * np.sqrt(2.0 / 4000)
    assert set(generator.intervals().robot.tolist()) <= set(range(90, 100))


def test_equal_bounds_give_that_duration_whatever_the_model():
    for duration_model in ("uniform", "gaussian"):
        generator = DelayGenerator(config(min_delay=7, max_delay=7, p_delay=0.3,
                                          duration_model=duration_model,
                                          gauss_std_ratio=3.0), 20)  # fmt: skip
        run(generator, 100)
        lengths = np.diff(np.stack(generator.intervals()[1:]), axis=0)
        assert set(lengths.ravel().tolist()) == {7}


def test_a_gaussian_without_spread_gives_its_mean_rounded_half_away_from_zero():
    # Mean 1 + 3 * 0.5 = 2.5: C's lround gives 3 (numpy's rint would give 2).
    generator = DelayGenerator(config(min_delay=1, max_delay=4, p_delay=1.0,
                                      duration_model="gaussian", gauss_mean_ratio=0.5,
                                      gauss_std_ratio=0.0), 4)  # fmt: skip
    run(generator, 1)
    assert generator.intervals_json() == [[[0, 3]]] * 4


# The statistics, with loose bounds (five standard deviations) over many ticks.


@pytest.mark.parametrize("p_delay", [0.002, 0.02, 0.3])
def test_bernoulli_hits_each_free_robot_with_chance_p_delay_a_tick(p_delay):
    robots, ticks = 200, 2000  # one-tick delays: every robot is free at every tick
    counts = new_delays_per_tick(DelayGenerator(config(p_delay=p_delay), robots), ticks)
    trials = robots * ticks
    expected, spread = trials * p_delay, np.sqrt(trials * p_delay * (1 - p_delay))
    assert abs(counts.sum() - expected) < 5 * spread


def test_bernoulli_hits_robots_alike_and_independently():
    robots, ticks, p_delay = 20, 5000, 0.1
    generator = DelayGenerator(config(p_delay=p_delay, seed=3), robots)
    delayed = run(generator, ticks)
    per_robot = delayed.sum(axis=0)
    spread = np.sqrt(ticks * p_delay * (1 - p_delay))
    assert (abs(per_robot - ticks * p_delay) < 5 * spread).all()
    # Independent: the number a tick is binomial (variance n p (1 - p)), not all-or-none.
    per_tick = delayed.sum(axis=1)
    assert 0.8 < per_tick.var() / (robots * p_delay * (1 - p_delay)) < 1.2


def test_poisson_counts_have_mean_and_variance_team_size_times_p_delay():
    robots, ticks, p_delay = 10, 4000, 0.5  # rate 5; a binomial would have variance 2.5
    generator = DelayGenerator(config(event_model="poisson", p_delay=p_delay, seed=1), robots)
    counts = new_delays_per_tick(generator, ticks)
    rate = robots * p_delay
    assert abs(counts.mean() - rate) < 5 * np.sqrt(rate / ticks)  # the cap at 10 is rare
    assert 0.85 < counts.var() / rate < 1.15


def test_uniform_durations_cover_the_range_evenly():
    generator = DelayGenerator(config(min_delay=1, max_delay=20, p_delay=0.05, seed=2), 500)
    run(generator, 400)
    start, end = generator.intervals()[1:]
    lengths = end - start
    assert lengths.min() == 1
    assert lengths.max() == 20
    assert abs(lengths.mean() - 10.5) < 5 * np.sqrt((20**2 - 1) / 12 / len(lengths))


def test_gaussian_durations_have_the_mean_and_spread_of_their_ratios():
    generator = DelayGenerator(config(min_delay=1, max_delay=41, p_delay=0.05, seed=4,
                                      duration_model="gaussian", gauss_mean_ratio=0.25,
                                      gauss_std_ratio=0.1), 500)  # fmt: skip
    run(generator, 400)
    start, end = generator.intervals()[1:]
    lengths = end - start  # mean 1 + 40 * 0.25 = 11, deviation 4: clipping is rare
    assert abs(lengths.mean() - 11) < 5 * 4 / np.sqrt(len(lengths))
    assert 3.6 < lengths.std() < 4.4


def test_gaussian_durations_are_clipped_to_the_range():
    generator = DelayGenerator(config(min_delay=2, max_delay=5, p_delay=0.2,
                                      duration_model="gaussian", gauss_mean_ratio=1.0,
                                      gauss_std_ratio=2.0), 200)  # fmt: skip
    run(generator, 200)
    start, end = generator.intervals()[1:]
    lengths = end - start
    assert lengths.min() == 2
    assert lengths.max() == 5


# Every rule at once, over random configs.

CONFIGS = st.builds(
    DelayConfig,
    seed=st.integers(0, 2**32 - 1),
    min_delay=st.integers(1, 6),
    max_delay=st.integers(6, 15),
    event_model=st.sampled_from(["bernoulli", "poisson"]),
    p_delay=st.one_of(st.sampled_from([0.0, 1.0]), st.floats(0, 1)),
    duration_model=st.sampled_from(["uniform", "gaussian"]),
    gauss_mean_ratio=st.floats(0, 1),
    gauss_std_ratio=st.floats(0, 3),
)


@settings(max_examples=60)
@given(delays=CONFIGS, robots=st.integers(0, 30), ticks=st.integers(0, 60))
def test_every_rule_holds_for_any_config(delays, robots, ticks):
    generator = DelayGenerator(delays, robots)
    delayed = run(generator, ticks)
    robot, start, end = generator.intervals()
    # The masks are the intervals, each [start, end): held from start for end - start ticks.
    assert (delayed == masks_from_intervals(generator, ticks)).all()
    assert ((end - start >= delays.min_delay) & (end - start <= delays.max_delay)).all()
    assert ((start >= 0) & (start < ticks)).all()
    # Ordered by start, then robot; a robot is hit only once its last delay is over.
    assert (np.lexsort((robot, start)) == np.arange(len(robot))).all()
    for i, pairs in enumerate(generator.intervals_json()):
        assert all(b[0] >= a[1] for a, b in itertools.pairwise(pairs)), i
    if delays.p_delay == 0:
        assert len(robot) == 0
    if delays.p_delay == 1 and delays.event_model == "bernoulli":
        assert delayed.all()
    assert generator.tick == ticks


@settings(max_examples=20)
@given(delays=CONFIGS, robots=st.integers(1, 30))
def test_the_draws_depend_on_the_config_alone(delays, robots):
    first, second = DelayGenerator(delays, robots), DelayGenerator(delays, robots)
    assert (run(first, 40) == run(second, 40)).all()
    assert first.intervals_json() == second.intervals_json()


def test_another_seed_gives_other_delays():
    one = DelayGenerator(config(p_delay=0.1, seed=1), 50)
    two = DelayGenerator(config(p_delay=0.1, seed=2), 50)
    assert (run(one, 50) != run(two, 50)).any()


def delays_digest(seed: int) -> str:
    """A digest of 300 ticks of poisson, gaussian delays on 64 robots, and their intervals."""
    delays = DelayConfig(seed, 1, 12, "poisson", 0.02, "gaussian", 0.4, 0.3)
    generator = DelayGenerator(delays, 64)
    digest = hashlib.sha256(run(generator, 300).tobytes())
    digest.update(json.dumps(generator.intervals_json()).encode())
    return digest.hexdigest()


def test_the_delays_are_bit_identical_in_another_process(run_python):
    here = delays_digest(5)
    there = run_python(
        "from tests.execution.test_delays import delays_digest; print(delays_digest(5))"
    )
    assert there.strip() == here
    assert delays_digest(6) != here


# Intervals, LoRR's output, memory.


def test_intervals_json_is_lorrs_delay_intervals():
    generator = DelayGenerator(config(min_delay=2, max_delay=3, p_delay=0.2, seed=7), 5)
    run(generator, 30)
    written = generator.intervals_json()
    assert len(written) == 5
    robot, start, end = generator.intervals()
    for i in range(5):
        mine = robot == i
        assert written[i] == np.stack([start[mine], end[mine]], axis=1).tolist()
    assert json.loads(json.dumps(written)) == written  # plain ints, JSON as is
    assert generator.intervals_json() == written  # reading twice changes nothing
    run(generator, 5)
    assert generator.intervals_json()[0][: len(written[0])] == written[0]  # kept, added to


def test_intervals_are_fresh_arrays():
    generator = DelayGenerator(config(p_delay=1.0), 2)
    run(generator, 3)
    intervals = generator.intervals()
    intervals.robot[:] = 9
    assert generator.intervals().robot.tolist() == [0, 1, 0, 1, 0, 1]


def test_an_empty_team_and_no_ticks_are_fine():
    generator = DelayGenerator(config(p_delay=1.0, event_model="poisson"), 0)
    assert run(generator, 5).shape == (5, 0)
    assert generator.intervals_json() == []
    assert DelayGenerator(config(), 3).intervals_json() == [[], [], []]


@pytest.mark.skipif(not CAN_MEASURE, reason="needs /proc to read resident memory")
def test_ticks_without_delays_store_nothing():
    generator = DelayGenerator(config(p_delay=0.0), 100_000)
    run_quietly = generator.next_tick
    for _ in range(50):
        run_quietly()
    before = resident_bytes()
    for _ in range(2000):  # a mask a tick would be 200 MB
        run_quietly()
    assert resident_bytes() - before < 20 << 20
    assert len(generator.intervals().robot) == 0


# The config: LoRR's JSON, its checks.


@pytest.mark.parametrize(
    ("relative", "expected"),
    [
        ("2026-examples-random/random-example_400.json",
         DelayConfig(0, 1, 4, "bernoulli", 0.01, "uniform", 0.5, 0.22)),
        ("2026-examples-maze/maze-example_40.json",
         DelayConfig(0, 5, 12, "bernoulli", 0.0003, "gaussian", 0.5, 0.22)),
    ],
)  # fmt: skip
def test_the_2026_examples_delay_configs_read_into_the_config(relative, expected):
    if not LORR.is_dir():
        pytest.skip(f"LoRR instances not found at {LORR} (the shared folder beside the checkout)")
    raw = json.loads((LORR / relative).read_text())["delayConfig"]
    assert DelayConfig.from_json(raw) == expected
    assert expected.to_json() == raw
    instance = read_instance(LORR / relative)
    assert DelayConfig.from_json(instance.delay.to_json()) == expected
    generator = DelayGenerator(expected, instance.team_size)
    assert run(generator, 50).shape == (50, instance.team_size)


def test_from_json_needs_every_field_as_lorr_does_and_ignores_others():
    full = config(duration_model="gaussian", gauss_std_ratio=0.22).to_json()
    assert DelayConfig.from_json({**full, "note": "ignored"}) == DelayConfig.from_json(full)
    del full["gaussStdRatio"]
    with pytest.raises(ValueError, match=r"^delayConfig is missing 'gaussStdRatio'$"):
        DelayConfig.from_json(full)
    with pytest.raises(ValueError, match=r"^delayConfig must be an object, got"):
        DelayConfig.from_json([1, 2])


def test_the_ratios_default_to_lorrs_and_integers_become_plain_ints():
    delays = DelayConfig(np.uint32(3), np.int64(2), 5, "poisson", 1, "uniform")
    assert (delays.gauss_mean_ratio, delays.gauss_std_ratio) == (0.5, 0.0)
    assert [type(getattr(delays, name)) for name in ("seed", "min_delay", "p_delay")] == [
        int, int, float
    ]  # fmt: skip
    assert json.loads(json.dumps(delays.to_json())) == delays.to_json()


def test_a_uniform_config_keeps_ratios_lorr_would_not_check():
    # LoRR checks the gaussian's ratios only for gaussian durations; so does this.
    assert config(gauss_mean_ratio=2.0, gauss_std_ratio=-1.0).gauss_mean_ratio == 2.0


@pytest.mark.parametrize(
    ("changes", "error", "words"),
    [
        ({"seed": -1}, ValueError, r"seed \(delayConfig.seed\) must be 0 to 4,294,967,295"),
        ({"seed": 2**32}, ValueError, r"seed \(delayConfig.seed\) must be 0 to"),
        ({"seed": True}, TypeError, r"seed \(delayConfig.seed\) must be an integer, got True"),
        ({"seed": 1.0}, TypeError, r"seed \(delayConfig.seed\) must be an integer, got 1.0"),
        ({"min_delay": 0}, ValueError, r"min_delay \(delayConfig.minDelay\) must be 1 to"),
        ({"min_delay": 2.5}, TypeError, r"min_delay \(delayConfig.minDelay\) must be an integer"),
        ({"min_delay": float("nan")}, TypeError, r"min_delay \(delayConfig.minDelay\) must be"),
        ({"max_delay": False}, TypeError, r"max_delay \(delayConfig.maxDelay\) must be an integ"),
        ({"min_delay": 3, "max_delay": 2}, ValueError,
         r"max_delay \(delayConfig.maxDelay\) must be at least min_delay \(3\), got 2"),
        ({"max_delay": 2**31}, ValueError, r"max_delay \(delayConfig.maxDelay\) must be 1 to "
         "2,147,483,647"),
        ({"event_model": "normal"}, ValueError,
         r"event_model \(delayConfig.eventModel\) must be one of bernoulli, poisson; got 'nor"),
        ({"event_model": 0}, ValueError, r"event_model \(delayConfig.eventModel\) must be one"),
        ({"duration_model": "Uniform"}, ValueError,
         r"duration_model \(delayConfig.durationModel\) must be one of uniform, gaussian"),
        ({"p_delay": -0.1}, ValueError, r"p_delay \(delayConfig.pDelay\) must be in \[0, 1\]"),
        ({"p_delay": 1.5}, ValueError, r"p_delay \(delayConfig.pDelay\) must be in \[0, 1\], g"),
        ({"p_delay": float("nan")}, ValueError, r"p_delay \(delayConfig.pDelay\) must be finite"),
        ({"p_delay": float("inf")}, ValueError, r"p_delay \(delayConfig.pDelay\) must be finite"),
        ({"p_delay": True}, TypeError, r"p_delay \(delayConfig.pDelay\) must be a number, got T"),
        ({"p_delay": "0.1"}, TypeError, r"p_delay \(delayConfig.pDelay\) must be a number"),
        ({"duration_model": "gaussian", "gauss_mean_ratio": 1.2}, ValueError,
         r"gauss_mean_ratio \(delayConfig.gaussMeanRatio\) must be in \[0, 1\], got 1.2"),
        ({"duration_model": "gaussian", "gauss_std_ratio": -0.1}, ValueError,
         r"gauss_std_ratio \(delayConfig.gaussStdRatio\) must be at least 0, got -0.1"),
        ({"gauss_std_ratio": float("nan")}, ValueError,
         r"gauss_std_ratio \(delayConfig.gaussStdRatio\) must be finite"),
    ],
)  # fmt: skip
def test_a_bad_config_is_one_line_naming_the_field(changes, error, words):
    with pytest.raises(error) as caught:
        config(**changes)
    assert caught.match(f"^{words}")
    assert "\n" not in str(caught.value)


def test_a_bad_team_or_config_is_refused_by_the_generator():
    with pytest.raises(TypeError, match=r"^config must be a DelayConfig, got dict$"):
        DelayGenerator(config().to_json(), 3)
    with pytest.raises(ValueError, match=r"^n_robots must be 0 to 1,000,000, got -1$"):
        DelayGenerator(config(), -1)
    with pytest.raises(TypeError, match=r"^n_robots must be an integer, got True"):
        DelayGenerator(config(), True)
