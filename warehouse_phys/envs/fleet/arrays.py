"""A fleet's arrays out: every robot's observation, reward and info as arrays (its array
form, :mod:`~warehouse_phys.envs.array_form`) and as PettingZoo's dicts.

:class:`FleetArrayForm` is the part of :class:`~warehouse_phys.envs.fleet.WarehouseFleetEnv`
that gives a step's outcome: the info columns of the live robots (one array a key, the
info dicts' order), the dicts made from them, and ``reset_arrays``/``step_arrays``, the
episode with arrays in robot order. The environment runs the step itself
(``_joint_step``); this part only reads its state.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from warehouse_phys.envs.array_form import ArrayStep, action_array
from warehouse_phys.envs.fleet.observations import robot_infos
from warehouse_phys.world.batched import step_rewards

if TYPE_CHECKING:
    from warehouse_phys.physics.safety import SafetyRecord

__all__ = ["FleetArrayForm"]


class FleetArrayForm:
    """A base class of :class:`~warehouse_phys.envs.fleet.WarehouseFleetEnv`: its array form
    and its infos (see the module)."""

    safety: SafetyRecord | None

    def reset_arrays(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """:meth:`~warehouse_phys.envs.fleet.WarehouseFleetEnv.reset`, with every robot's
        observation a row of one array and each info an ``(N,)`` array
        (:mod:`~warehouse_phys.envs.array_form`)."""
        observations, _ = self.reset(seed, options)
        every = self._every_robot
        refused = np.zeros(self.num_robots, dtype=bool)
        return np.stack(list(observations.values())), self._info_columns(every, refused, None,
                                                                         None)  # fmt: skip

    def step_arrays(self, actions: np.ndarray) -> ArrayStep:
        """:meth:`~warehouse_phys.envs.fleet.WarehouseFleetEnv.step` with ``actions`` an
        ``(N,)`` integer array in robot order (a robot no longer live waits, whatever its
        entry), and arrays back for every robot
        (:class:`~warehouse_phys.envs.array_form.ArrayStep`: a robot that terminated before
        keeps its last observation, a reward of 0 and ``terminations`` True)."""
        if not self.agents:
            raise ValueError("the episode is over (no live robots): call reset()")
        live = self._live_indices()
        joint = action_array(actions, self.num_robots, self._actions.count,
                             f"0..{self._actions.wait} ({self._actions.wait} is WAIT)")  # fmt: skip
        gone = np.ones(self.num_robots, dtype=bool)
        gone[live] = False
        joint[gone] = self._actions.wait
        return self._joint_step(joint, live, arrays=True)

    def _array_step(self, live: np.ndarray, arrived: np.ndarray, refused: np.ndarray,
                    snap_errors: np.ndarray | None, gaps: np.ndarray | None,
                    truncated: bool) -> ArrayStep:  # fmt: skip
        """The arrays of a step of every robot (``live``: those that moved in it)."""
        n, every = self.num_robots, self._every_robot
        moved = np.zeros(n, dtype=bool)
        moved[live] = True
        ended = ~moved | (arrived & moved & (not self.lifelong))
        observations = self._observer.observe(
            self.possible_agents, None, self._cells, self._packages, self._headings, self._on_floor
        )
        return ArrayStep(
            np.stack(list(observations.values())), step_rewards(arrived & moved), ended,
            np.full(n, truncated) & ~ended,
            self._info_columns(every, refused, snap_errors, gaps),
        )  # fmt: skip

    def _infos(
        self,
        live: np.ndarray,
        refused: np.ndarray,
        snap_errors: np.ndarray | None,
        gaps: np.ndarray | None,
    ) -> dict[str, dict[str, Any]]:
        columns = self._info_columns(live, refused, snap_errors, gaps)
        firsts = [columns.pop(key).tolist() for key in ("optimal_steps", "refused", "deliveries")]
        extra = {key: value.tolist() for key, value in columns.items()}
        return robot_infos(self.agents, *firsts, extra)

    def _info_columns(
        self,
        live: np.ndarray,
        refused: np.ndarray,
        snap_errors: np.ndarray | None,
        gaps: np.ndarray | None,
    ) -> dict[str, np.ndarray]:
        """The ``live`` robots' infos, an array a key, in the info dicts' order."""
        all_live = len(live) == self.num_robots  # no copies in the usual case
        here, packages, deliveries = self._here, self._package_index, self._deliveries
        if not all_live:
            here, packages, refused, deliveries = (
                a[live] for a in (here, packages, refused, deliveries)
            )
        columns = {"optimal_steps": self.distances.lookup(here, packages), "refused": refused,
                   "deliveries": deliveries}  # fmt: skip
        if self._errands is not None:
            columns["tasks"] = self._errands.tasks_per_robot[live]
        if self.physics:
            if snap_errors is None:  # at a reset
                snap_errors, gaps = np.zeros(self.num_robots), np.full(self.num_robots, np.inf)
            columns["snap_error"] = snap_errors[live].astype(float)
            if self.track_gaps:
                columns["min_gap"] = gaps[live].astype(float)
            record = self.safety
            if record is not None:
                columns |= {"closest_approach": record.robot_closest[live],
                            "body_contacts": record.robot_body_contacts[live],
                            "wall_contacts": record.robot_wall_contacts[live]}  # fmt: skip
        return columns
