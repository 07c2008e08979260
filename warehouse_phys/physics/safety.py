"""How safe the bodies kept, measured at every physics step: the closest approach of two
bodies, and the contacts deeper than the engine's collision slop, body to body and body
to wall.

Chipmunk lets touching shapes overlap by up to its collision slop ``s``
(:data:`~warehouse_phys.physics.engine.COLLISION_SLOP` cells) before it pushes them apart:
an overlap within the slop is a resting contact, deeper is a collision. The physics
twin's guarantees are about that bound: in lock step the traffic rule and the fleet's
clearance check, on ticks the clearance formula of :mod:`~warehouse_phys.physics.ticking`
keep every two discs of diameter ``d`` at least ``d - s`` apart, and every disc off the
walls and shelves (a lock-step move *bumped* into a wall sinks in a little, up to
:data:`~warehouse_phys.physics.config.PENETRATION_TOLERANCE`). :class:`SafetyRecord`
measures what the bodies actually did, from their positions after every physics step (the
batched world's recorded paths):

- **closest approach**: the smallest distance between two bodies' centres [cells], each
  robot's and the fleet's, exact whenever it is below :data:`MEASURED_WITHIN` (the pairs
  compared are every pair that started a step within ``MEASURED_WITHIN`` plus twice the
  farthest any body travelled in it, so none that came closer is missed); ``inf`` for a
  robot that no body came that close to;
- **body contacts**: the pairs of bodies closer than ``d - s`` (deeper than the slop),
  counted once for each tick or move in which they were, and the deepest overlap [cells];
- **wall contacts**: the bodies deeper than ``s`` into a wall or shelf, counted once for
  each tick or move in which they were, and the deepest [cells];
- **split contacts**: in a world split into regions
  (:mod:`~warehouse_phys.physics.regions`), pairs of bodies in different regions that
  came within ``d`` of each other, whose contact no space simulated (the split's promise
  is that there are none).

Each step costs two compiled passes over the step's positions
(:mod:`~warehouse_phys.physics.regions.proximity`): about 0.1 µs a body and physics step.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from warehouse_phys.physics.config import PhysicsConfig
from warehouse_phys.physics.engine import COLLISION_SLOP
from warehouse_phys.physics.regions.proximity import (
    largest_travel,
    near_pairs,
    pair_closest,
    wall_depths,
)
from warehouse_phys.world.grid import WarehouseGrid

#: Closest approaches below this are measured exactly; beyond it a robot's is ``inf``
#: (no body came within it) [cells].
MEASURED_WITHIN = 1.0


class SafetyRecord:
    """The closest approach and the contacts deeper than the collision slop of ``n_robots``
    discs of ``config`` on ``grid`` (see the module), since it was made or :meth:`clear`-ed.

    Fleet-wide: :attr:`closest_approach` [cells], :attr:`body_contacts`,
    :attr:`wall_contacts`, :attr:`split_contacts`, :attr:`deepest_body` and
    :attr:`deepest_wall` [cells, 0 for none], :attr:`steps` (physics steps measured);
    per robot: :attr:`robot_closest` ``(N,)`` [cells], :attr:`robot_body_contacts` and
    :attr:`robot_wall_contacts` ``(N,)`` int64. :attr:`bound` is ``d - s``, the least
    distance between two centres that the twin promises [cells].
    """

    def __init__(self, n_robots: int, grid: WarehouseGrid, config: PhysicsConfig) -> None:
        self.n_robots = n_robots
        #: The discs' diameter ``d`` and the collision slop ``s`` [cells].
        self.diameter, self.slop = config.robot_diameter, COLLISION_SLOP
        #: ``d - s``: two centres never closer, as the twin promises [cells].
        self.bound = self.diameter - self.slop
        blocked = np.ones((grid.rows + 2, grid.cols + 2), dtype=bool)
        blocked[1:-1, 1:-1] = grid.shelf_mask
        self._blocked = blocked
        self.clear()

    def clear(self) -> None:
        """Forget everything measured (a new episode)."""
        n = self.n_robots
        self.robot_closest = np.full(n, np.inf)
        self.robot_body_contacts = np.zeros(n, dtype=np.int64)
        self.robot_wall_contacts = np.zeros(n, dtype=np.int64)
        self.body_contacts = self.wall_contacts = self.split_contacts = self.steps = 0
        self.deepest_body = self.deepest_wall = 0.0

    @property
    def closest_approach(self) -> float:
        """The closest two bodies' centres came [cells] (``inf``: never within
        :data:`MEASURED_WITHIN`)."""
        return float(self.robot_closest.min(initial=np.inf))

    def observe(
        self,
        path: np.ndarray,
        origin: np.ndarray,
        size: float,
        floors: np.ndarray,
        regions: np.ndarray | None = None,
    ) -> None:
        """Measure one tick's or move's physics steps: ``path`` ``(steps, N, 2)``, every
        body's ``(x, y)`` [m] after each, ``origin`` ``(N, 2)`` the corner of each robot's
        floor [m], ``size`` the cell's side [m], ``floors`` ``(N,)`` each robot's floor and
        ``regions`` ``(N,)`` each robot's region (``None``: one space)."""
        if not len(path):
            return
        self.steps += len(path)
        travel = largest_travel(path)
        radius = MEASURED_WITHIN * size + 2 * travel
        pairs = near_pairs(np.ascontiguousarray(path[0]), floors, radius)
        apart = pair_closest(path, pairs) / size
        near = apart < MEASURED_WITHIN
        for side in (0, 1):
            np.minimum.at(self.robot_closest, pairs[near, side], apart[near])
        deeper = apart < self.bound
        if deeper.any():
            self.body_contacts += int(deeper.sum())
            self.deepest_body = max(self.deepest_body, float((self.diameter - apart).max()))
            for side in (0, 1):
                np.add.at(self.robot_body_contacts, pairs[deeper, side], 1)
        if regions is not None:
            apart_regions = regions[pairs[:, 0]] != regions[pairs[:, 1]]
            self.split_contacts += int(((apart < self.diameter) & apart_regions).sum())
        depth = wall_depths(path, origin, size, self._blocked, self.diameter / 2)
        into = depth > self.slop
        if into.any():
            self.wall_contacts += int(into.sum())
            self.robot_wall_contacts += into
            self.deepest_wall = max(self.deepest_wall, float(depth.max()))

    def summary(self) -> dict[str, Any]:
        """The fleet-wide measures as JSON-ready numbers (``closest_approach`` ``None``
        when no two bodies came within :data:`MEASURED_WITHIN`)."""
        closest = self.closest_approach
        return {
            "closest_approach": None if np.isinf(closest) else closest,
            "closest_approach_bound": self.bound,
            "body_contacts": self.body_contacts,
            "wall_contacts": self.wall_contacts,
            "split_contacts": self.split_contacts,
            "deepest_body_contact": self.deepest_body,
            "deepest_wall_contact": self.deepest_wall,
            "collision_slop": self.slop,
            "physics_steps_measured": self.steps,
        }
