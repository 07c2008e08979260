"""A fleet's actions checked: the joint action of a step, or one robot's (the AEC form).

:class:`FleetActions` turns the dict a PettingZoo ``step`` receives into the joint action
array of the traffic rule, refusing anything else with a ``TypeError``/``ValueError``
that names the robot, before anything changes. The usual case (every live robot, in
order, with a plain integer) costs one array conversion. :func:`aec_form` is the fleet
as a PettingZoo AEC environment, whose robots' actions are checked as they are given.
"""

from __future__ import annotations

import numpy as np
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec_wrapper
from pettingzoo.utils.wrappers import OrderEnforcingWrapper

from warehouse_phys.envs.checks import INTEGER_TYPES, number_text

__all__ = ["FleetAEC", "FleetActions", "aec_form"]


class FleetActions:
    """The actions of ``num_robots`` robots, each ``0..count - 1`` (the last is WAIT,
    given to robots that are not live)."""

    def __init__(self, num_robots: int, count: int, index: dict[str, int]) -> None:
        self.num_robots = num_robots
        self.count = count
        #: WAIT is the last action of both move models.
        self.wait = count - 1
        self._index = index

    def joint(self, actions: object, agents: list[str], live: np.ndarray) -> np.ndarray:
        """The joint action (WAIT for robots not live), or an error naming the robot."""
        if not isinstance(actions, dict):
            raise TypeError(
                f"actions must be a dict of robot to action, got {type(actions).__name__}"
            )
        # The usual case first: every live robot, in order, with a plain integer.
        if list(actions) == agents and set(map(type, actions.values())) <= INTEGER_TYPES:
            try:
                values = np.fromiter(actions.values(), np.int64, len(actions))
            except OverflowError:  # beyond 64 bits: refused below, robot by robot
                values = np.full(len(actions), self.count, dtype=np.int64)
            if not np.count_nonzero(values.view(np.uint64) >= self.count):  # negatives: huge
                if len(values) == self.num_robots:
                    return values
                joint = np.full(self.num_robots, self.wait, dtype=np.int64)
                joint[live] = values
                return joint
        joint = np.full(self.num_robots, self.wait, dtype=np.int64)
        unknown = [agent for agent in actions if agent not in agents]
        if unknown:
            raise ValueError(f"actions for robots that are not live: {unknown}; live: {agents}")
        missing = [agent for agent in agents if agent not in actions]
        if missing:
            raise ValueError(f"no action for {missing}")
        for agent, action in actions.items():
            joint[self._index[agent]] = self.one(agent, action)
        return joint

    def one(self, agent: str, action: object) -> int:
        """``action`` as an int of the action space, or a ``TypeError``/``ValueError``
        naming ``agent``."""
        is_integer = (
            isinstance(action, (int, np.integer)) and not isinstance(action, np.timedelta64)
        ) or (isinstance(action, np.ndarray) and action.shape == () and action.dtype.kind in "iu")
        top = self.wait
        if isinstance(action, (bool, np.bool_)) or not is_integer:
            raise TypeError(f"{agent}'s action must be an integer 0..{top}, got {action!r}")
        if np.ma.is_masked(action):
            raise ValueError(f"{agent}'s action is masked: it has no value")
        if not 0 <= int(action) < self.count:
            raise ValueError(
                f"{agent}'s action must be 0..{top} ({top} is WAIT), got {number_text(action)}"
            )
        return int(action)


class FleetAEC(parallel_to_aec_wrapper):
    """PettingZoo's AEC form of the fleet, refusing a bad action when it is given (the
    joint step happens at the last robot's turn, too late to refuse it cleanly)."""

    def step(self, action: int | None) -> None:
        agent = self.agent_selection
        if not (self.terminations[agent] or self.truncations[agent]):
            action = self.env.checked_action(agent, action)
        super().step(action)


def aec_form(fleet: ParallelEnv) -> AECEnv:
    """``fleet`` (a :class:`~warehouse_phys.envs.fleet.WarehouseFleetEnv`) as a PettingZoo
    AEC environment: robots act in turn, their moves happen together, and each robot's
    action is checked by the fleet's :class:`FleetActions` as it is given."""
    return OrderEnforcingWrapper(FleetAEC(fleet))
