"""The tick controller check: the tracking error measured on probes, the clearance formula
built on it, and settings the bodies cannot follow refused with one line naming them."""

import pytest

from warehouse_phys.physics import (
    COLLISION_SLOP,
    HEADING_SNAP_BOUND,
    SNAP_ERROR_BOUND,
    PhysicsConfig,
)
from warehouse_phys.physics.tick_controller import check_tick_controller, required_min_gap
from warehouse_phys.physics.ticking import QUARTER, TRACKING_MARGIN, default_tick_steps

CONFIG = PhysicsConfig()


def test_the_clearance_formula_is_the_modules():
    motion = check_tick_controller(CONFIG, 10)
    reach = motion.tracking_error + TRACKING_MARGIN
    expected = CONFIG.robot_diameter - COLLISION_SLOP + 2 * reach
    assert required_min_gap(CONFIG, 10) == pytest.approx(expected, abs=1e-12)
    # The default robot at 10 ticks a move: 4 steps a tick, a cell in 40 steps, and the
    # body a step behind at a move's start: e = 1/40 cell.
    assert default_tick_steps(CONFIG, 10) == 4
    assert motion.tracking_error == pytest.approx(1 / 40, abs=1e-9)
    assert motion.snap_error < SNAP_ERROR_BOUND / 2
    assert check_tick_controller(CONFIG, 10, 4) is motion  # cached


@pytest.mark.parametrize(
    ("config", "ticks", "steps", "match"),
    [
        (CONFIG, 5, 1, "faster than max_speed 6 m/s; use at least 10 ticks a move"),
        (CONFIG, 10, 1, "it could touch a wall"),
        (CONFIG, 3, 5, "from the centre, not within half the bound"),
        (PhysicsConfig(max_force=300.0), 3, 5, r"move from \(0, 0\) to \(0, 1\) ends on \(0, 0\)"),
        (PhysicsConfig(robot_radius=0.48), 10, 6, "need a min_gap of 1.01 cells, more than one"),
    ],
)
def test_settings_the_bodies_cannot_follow_are_refused_naming_them(config, ticks, steps, match):
    with pytest.raises(ValueError, match=match) as raised:
        required_min_gap(config, ticks, steps)
    assert f"ticks_per_move {ticks}" in str(raised.value)
    assert "\n" not in str(raised.value)
    with pytest.raises(ValueError, match="ticks_per_move"):
        check_tick_controller(CONFIG, 0)
    with pytest.raises(TypeError, match="tick_steps"):
        check_tick_controller(CONFIG, 3, 2.5)


def test_the_turning_check_measures_angles_and_counts_turns_in_e():
    for ticks in (3, 10):
        steps = default_tick_steps(CONFIG, ticks)
        motion = check_tick_controller(CONFIG, ticks, turning=True)
        # A turn is a quarter turn in ticks x steps steps; the body a step behind at its start.
        assert motion.angle_error == pytest.approx(QUARTER / (ticks * steps), rel=1e-9)
        assert motion.heading_error < HEADING_SNAP_BOUND / 2
        assert motion.tracking_error >= check_tick_controller(CONFIG, ticks).tracking_error
        reach = motion.tracking_error + TRACKING_MARGIN
        expected = CONFIG.robot_diameter - COLLISION_SLOP + 2 * reach
        assert required_min_gap(CONFIG, ticks, turning=True) == pytest.approx(expected, abs=1e-12)
        assert check_tick_controller(CONFIG, ticks, steps, turning=True) is motion  # cached
    # A setting whose moves pass but whose turns end too far off their heading.
    config = PhysicsConfig(gain=20.0)
    assert check_tick_controller(config, 10, 4).snap_error < SNAP_ERROR_BOUND / 2
    with pytest.raises(ValueError, match=r"ticks_per_move 10 .* rad off its heading") as raised:
        required_min_gap(config, 10, 4, turning=True)
    assert "\n" not in str(raised.value)
