"""Text frames: the single robot's and the fleet's console pictures."""

import gymnasium as gym

from warehouse_phys import Action
from warehouse_phys.drawing.text_frames import ansi_frame, fleet_ansi_frame

ENV_ID = "warehouse-robot-v0"


def test_ansi_picture_is_exact():
    env = gym.make(ENV_ID, render_mode="ansi")
    env.reset(options={"target": (2, 3)})
    env.step(Action.RIGHT)
    assert env.render() == "_ R _ _ _ \n_ _ _ _ _ \n_ _ _ T _ \n_ _ _ _ _ \n"


def test_ansi_draws_the_robot_over_the_target():
    assert ansi_frame(2, 3, robot=(1, 1), target=(1, 1)) == "_ _ _ \n_ R _ \n"


def test_fleet_ansi_frame_draws_robots_over_packages_and_hides_robots_off_the_floor():
    frame = fleet_ansi_frame(
        2, 3, robots=[(0, 0), (1, 2), (1, 1)], packages=[(1, 2), (0, 1), (0, 2)],
        shown=[True, True, False], shelves={(1, 0)},
    )  # fmt: skip
    # Robot 1 stands on robot 0's package; robot 2 and its package are not shown.
    assert frame == "0 b _\n# _ 1"
