"""A fleet's robots as bodies: the physics world started at a reset, each step's granted
moves driven through it, and the frames of its motion.

The fleet (:class:`~warehouse_phys.envs.fleet.WarehouseFleetEnv` with ``physics=True``)
keeps one :class:`~warehouse_phys.physics.batched.BatchedPhysicsWorld`, built by its
first reset and restarted after (every robot as newly built, in the same world). A step
drives the moves the traffic rule granted and the bumps it refused, holds the rest, and
reads the cells (and a turning robot's heading) back from the bodies.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from warehouse_phys.drawing.render import WarehouseRenderer
from warehouse_phys.physics import PhysicsConfig
from warehouse_phys.world.grid import WarehouseGrid

if TYPE_CHECKING:
    from warehouse_phys.physics.batched import BatchedPhysicsWorld

__all__ = ["drive_bodies", "motion_frames", "started_world"]


def started_world(
    world: BatchedPhysicsWorld | None,
    grid: WarehouseGrid,
    physics: PhysicsConfig,
    cells: np.ndarray,
    headings: np.ndarray | None,
    *,
    record_path: bool,
    threads: int = 1,
    safety: bool = False,
) -> BatchedPhysicsWorld:
    """``world`` with every robot as newly built on ``cells`` (``(N, 2)``), facing
    ``headings`` (turning robots); built on ``grid`` when ``world`` is ``None``
    (``record_path``: whether each step records every body's path; ``threads``, its
    regions; ``safety``: whether it measures every physics step)."""
    n = len(cells)
    if world is None:
        # Imported at the first reset of a fleet of bodies: every command that imports the
        # fleets would otherwise pay for the bodies' SciPy and numba (0.5 s).
        from warehouse_phys.physics.batched import BatchedPhysicsWorld

        return BatchedPhysicsWorld(
            grid, physics, cells, np.zeros(n, dtype=np.int64), record_path=record_path,
            headings=headings, threads=threads, safety=safety,
        )  # fmt: skip
    world.restart(np.arange(n), cells, headings)  # every robot as newly built, in the same world
    return world


def drive_bodies(
    world: BatchedPhysicsWorld,
    joint: np.ndarray,
    ends: np.ndarray,
    bumped: np.ndarray,
    headings: np.ndarray | None,
    *,
    turning: bool,
    track_gaps: bool,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, np.ndarray | None]:
    """Drive a step's moves as the traffic rule granted them (``joint``: the actions;
    ``ends``: the granted cells, ``(N, 2)``; ``bumped``: the moves a wall or shelf
    refused, driven towards it and back; a turning fleet's granted ``headings``),
    holding the other robots.

    Returns ``(cells, headings, snap_errors, gaps)``: the cells read from the bodies
    (``(N, 2)`` int64, the grid twin's, as the tests prove), the headings read from the
    bodies (``headings`` itself for robots that do not turn), each body's distance to
    its cell's centre before the snap [cells], and each robot's closest approach during
    the step (``None`` unless ``track_gaps``) [cells].
    """
    if turning:  # the headings read from the bodies too
        body_cells, headings, snap_errors = world.move_turning(ends, headings, bumped)
    else:
        body_cells, snap_errors = world.move_granted(joint, ends, bumped)
    cells = np.asarray(body_cells, dtype=np.int64).reshape(-1, 2)
    gaps = world.closest_gaps() if track_gaps else None
    return cells, headings, snap_errors, gaps


def motion_frames(
    world: BatchedPhysicsWorld | None,
    renderer: WarehouseRenderer,
    packages: list[tuple[int, int]],
    *,
    turning: bool,
) -> list[np.ndarray]:
    """The frames of the last step's motion in ``world``, one per physics step (the last
    just before the snap), as ``(H, W, 3)`` uint8 arrays; needs no display.

    Raises:
        ValueError: without a world (the grid twin, which has no motion between cells),
            or if the world does not record its paths.
    """
    if world is None:
        raise ValueError("only the physics world (physics=True) has motion frames")
    if not world.record_path:
        raise ValueError(
            "this fleet does not record the motion: make it with render_mode='rgb_array' "
            "or track_gaps=True"
        )
    paths = world.last_paths  # (K, steps, 2)
    turns = world.last_orientations if turning else None  # (K, steps)
    return [
        renderer.fleet_rgb_array(
            paths[:, step].tolist(), packages,
            headings=None if turns is None else turns[:, step].tolist(),
        )
        for step in range(paths.shape[1])
    ]  # fmt: skip
