"""The floor split into regions, one pymunk space each, stepped on several cores at once.

A :class:`~warehouse_phys.physics.batched.BatchedPhysicsWorld` built with ``threads=K``
(``K > 1``) holds its robots' bodies in :class:`RegionRows`: ``K`` spaces, each with every
wall and shelf of the floor and the bodies of the robots in one band of columns
(:mod:`~warehouse_phys.physics.regions.bands`). Each physics step runs ``cpSpaceStep`` on
every space, the spaces in parallel threads (chipmunk's step releases the GIL).

**Why this is exact.** Chipmunk solves each contact and joint from the two bodies it
joins; a robot's body is joined to nothing but its own control body (by its pivot joint,
and a turning robot's gear joint), the static walls and the bodies it touches. So a robot
that touches no other robot moves, bit for bit, the same in any space that holds the
same walls in the same order (its contacts with them come out of the static index in the
same order), whatever else the space holds. Before every tick or lock-step move, robots
whose paths may bring their bodies into contact are put in one region
(:func:`~warehouse_phys.physics.regions.bands.region_of_robots`); a robot that changes
region is taken out of its space and put in the other's whole (body, disc, control body,
joints: position, velocity, angle, spin and the joints' accumulated impulses travel with
the C objects). So:

- every contact is simulated: two bodies that can touch are in one space (the safety
  measures count ``split_contacts``, pairs of regions' bodies that came within a diameter:
  the tests find none);
- the bodies follow the one-space world bit for bit, whatever ``K``, as long as no two
  bodies touch and no body touches two walls in the step it changes region (the golden
  runs of the physics twin replay with 1, 2 and 3 threads);
- where bodies do touch, the order of their contacts in the solver depends on what their
  space holds, so the bits depend on ``K``; for a given ``K`` every step is a function of
  the state alone (the regions, the order of bodies in each space and each space's step),
  never of the threads' timing: the same seed gives the same bits in every process.

Every body of the spaces is read and written with pymunk's batched calls into one array
(:class:`RegionStates`: each region's bodies in a block of rows), so the world's code
reads and writes robots by row whatever the number of spaces. The rows follow chipmunk's
own arrays: a body taken out of a space leaves its place to the space's last body, a body
put in goes last (:meth:`RegionRows.check_rows` reads them back to prove it).
"""

from __future__ import annotations

import time
import weakref
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pymunk
import pymunk.batch

from warehouse_phys.physics.body_io import STATE_FIELDS, TURNING_STATE_FIELDS
from warehouse_phys.physics.config import PhysicsConfig
from warehouse_phys.physics.engine import (
    PositionReader,
    RobotBodies,
    add_robot,
    clear_time_step,
    renew_robot,
    space_stepping,
)
from warehouse_phys.physics.floor_lattice import FloorLattice
from warehouse_phys.physics.regions.bands import (
    SAFE_REACH,
    band_edges,
    home_bands,
    region_of_robots,
)

__all__ = ["MAX_THREADS", "RegionRows", "RegionStates", "check_threads"]

#: Most threads (regions) a world may step at once.
MAX_THREADS = 64
_BODY_ID = pymunk.batch.BodyFields.BODY_ID


def check_threads(threads: object) -> int:
    """``threads`` as an int from 1 to :data:`MAX_THREADS`, or a ``TypeError``/``ValueError``
    naming it."""
    if isinstance(threads, (bool, np.bool_)) or not isinstance(threads, (int, np.integer)):
        raise TypeError(f"threads must be a whole number, got {threads!r}")
    if not 1 <= threads <= MAX_THREADS:
        bits = int(threads).bit_length()
        shown = threads if bits < 64 else f"an integer of {bits} bits"
        raise ValueError(f"threads must be from 1 to {MAX_THREADS}, got {shown}")
    return int(threads)


class RegionStates:
    """Every body of several spaces: position, velocity and spin (and angle, with
    ``angles=True``), read and written with one batched call a space, into one array.

    :attr:`array` is ``(regions x capacity, width)`` as
    :class:`~warehouse_phys.physics.body_io.BodyStates`'s, region ``k``'s bodies in rows
    ``k capacity ...`` in its space's order; :attr:`counts` says how many each holds.
    """

    def __init__(self, spaces: Sequence[pymunk.Space], capacity: int, *, angles: bool) -> None:
        self.spaces, self.capacity = list(spaces), capacity
        width = 6 if angles else 5
        self._fields = TURNING_STATE_FIELDS if angles else STATE_FIELDS
        self.array = np.zeros((len(spaces) * capacity, width))
        self.positions = self.array[:, :2]
        self.angles = self.array[:, 2] if angles else None
        self.velocities = self.array[:, width - 3 : width - 1]
        self.spins = self.array[:, width - 1]
        self._buffers = []
        for k in range(len(spaces)):
            buffer = pymunk.batch.Buffer()
            buffer.set_float_buf(self.array[k * capacity : (k + 1) * capacity].reshape(-1))
            self._buffers.append(buffer)
        self.counts = [0] * len(spaces)

    def read(self, space: object = None) -> np.ndarray:
        """Read every body of every space into :attr:`array`; returns it (``space`` is
        ignored: the batched world's one-space call)."""
        width = self.array.shape[1]
        for space_k, buffer, count in zip(self.spaces, self._buffers, self.counts, strict=True):
            buffer.clear()
            pymunk.batch.get_space_bodies(space_k, self._fields, buffer)
            if len(buffer.float_buf()) != 8 * width * count:  # pragma: no cover - a lost body
                raise RuntimeError(f"a region's space no longer holds {count} bodies")
        return self.array

    def write(self, space: object = None) -> None:
        """Give every body the state in :attr:`array` (a state as read is kept exactly)."""
        for space_k, buffer in zip(self.spaces, self._buffers, strict=True):
            pymunk.batch.set_space_bodies(space_k, self._fields, buffer)


class RegionRows:
    """Robots' bodies held in ``n_regions`` spaces (see the module), with the interface of
    :class:`~warehouse_phys.physics.body_io.BodyRows`: each robot's and control body's row
    in :attr:`states`, batched reads and writes in robot order, and the physics steps.

    Args:
        lattice: The world's floors (every space gets all their walls and shelves).
        config: The robots' physical parameters.
        centre_xy: ``(N, 2)`` where each robot starts, at rest [m].
        angles: Each turning robot's angle [rad], or ``None`` for robots that do not turn.
        n_regions: How many spaces (and threads), at least 2.
    """

    def __init__(
        self,
        lattice: FloorLattice,
        config: PhysicsConfig,
        centre_xy: np.ndarray,
        angles: Sequence[float] | None,
        n_regions: int,
    ) -> None:
        self.lattice, self.config, self.n_regions = lattice, config, n_regions
        self.turning = angles is not None
        self.edges = band_edges(lattice.grid, n_regions)
        self.spaces = [lattice.new_space(config) for _ in range(n_regions)]
        region = home_bands(lattice.to_cells(centre_xy)[:, 1], self.edges)
        turns = [None] * len(centre_xy) if angles is None else list(angles)
        #: Every robot's bodies, in robot order.
        self.bodies: list[RobotBodies] = [
            add_robot(self.spaces[k], config, tuple(xy), angle)
            for xy, angle, k in zip(centre_xy.tolist(), turns, region.tolist(), strict=True)
        ]
        #: ``(N,)`` int64: the region (space) holding each robot.
        self.region = region.astype(np.int64)
        self._attach()

    def _attach(self) -> None:
        """Read where every body sits in its space, and make the buffers and the pool."""
        n = len(self.bodies)
        orders, totals = self.read_order()
        #: Bodies of each space that are not ours (its static body), after ours.
        self._static = [total - len(order) for order, total in zip(orders, totals, strict=True)]
        self.capacity = 2 * n + max(self._static) + 2
        self.states = RegionStates(self.spaces, self.capacity, angles=self.turning)
        self._readers = [PositionReader(0, angles=self.turning, capacity=self.capacity)
                         for _ in self.spaces]  # fmt: skip
        self._local = np.empty(2 * n, dtype=np.int64)
        for order in orders:
            self._local[order] = np.arange(len(order))
        self._order = [order.tolist() for order in orders]
        self._update_rows()
        self._pool: ThreadPoolExecutor | None = None
        #: CPU seconds each region's thread spent stepping, and the sum over the steps of
        #: the longest of them: the stepping's share of the wall time on idle cores.
        self.thread_seconds, self.critical_seconds = [0.0] * self.n_regions, 0.0

    def __getstate__(self) -> dict[str, object]:
        state = self.__dict__.copy()
        for name in ("states", "_readers", "_pool", "_order", "_local"):
            state.pop(name)
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self._attach()  # new C objects, and a space rebuilt in pymunk's order

    # ------------------------------------------------------------------ rows
    def read_order(self) -> tuple[list[np.ndarray], list[int]]:
        """Each space's robot and control bodies in the order chipmunk holds them, read back
        by id (``2 robot`` for a robot's body, ``2 robot + 1`` for its control body), and
        how many bodies each space holds in all."""
        ids = np.array([[b.robot.id, b.control.id] for b in self.bodies], dtype=np.uintp)
        keys = dict(zip(ids.reshape(-1).tolist(), range(ids.size), strict=True))
        orders, totals = [], []
        for space in self.spaces:
            buffer = pymunk.batch.Buffer()
            pymunk.batch.get_space_bodies(space, _BODY_ID, buffer)
            in_space = np.frombuffer(buffer.int_buf(), dtype=np.uintp).tolist()
            ours = [keys[i] for i in in_space if i in keys]
            if ours != [keys.get(i) for i in in_space[: len(ours)]]:  # pragma: no cover
                raise RuntimeError("a space holds other bodies among the robots'")
            orders.append(np.array(ours, dtype=np.int64))
            totals.append(len(in_space))
        return orders, totals

    def check_rows(self) -> None:
        """Raise a ``RuntimeError`` unless the rows kept follow the spaces' own order."""
        orders, _ = self.read_order()
        for k, (kept, read) in enumerate(zip(self._order, orders, strict=True)):
            if kept != read.tolist():
                raise RuntimeError(f"region {k}'s rows no longer follow its space")

    def _update_rows(self) -> None:
        base = self.region * self.capacity
        self.robot_rows = base + self._local[0::2]
        self.control_rows = base + self._local[1::2]
        self.body_rows = np.concatenate((self.robot_rows, self.control_rows))
        self._members = [np.flatnonzero(self.region == k) for k in range(self.n_regions)]
        self._member_rows = [self._local[2 * robots] for robots in self._members]
        for k, order in enumerate(self._order):
            count = len(order) + self._static[k]
            self.states.counts[k] = count
            self._readers[k].resize(count)

    # ------------------------------------------------------------------ regions
    def regroup(
        self, start: np.ndarray, end: np.ndarray, floors: np.ndarray, reach: float = SAFE_REACH
    ) -> int:
        """Put robots whose paths (``start`` to ``end``, ``(N, 2)`` cells) may bring their
        bodies together in one region (:func:`region_of_robots`); returns how many robots
        changed region."""
        regions = region_of_robots(start, end, floors, self.edges, reach)
        moving = np.flatnonzero(regions != self.region)
        for robot in moving.tolist():
            self._move(robot, int(regions[robot]))
        if len(moving):
            self._update_rows()
        return len(moving)

    def _move(self, robot: int, to: int) -> None:
        """Take ``robot``'s bodies out of their space and put them in region ``to``'s."""
        bodies, was = self.bodies[robot], int(self.region[robot])
        old, new = self.spaces[was], self.spaces[to]
        joints = [bodies.joint] if bodies.gear is None else [bodies.joint, bodies.gear]
        for part in (*joints, bodies.shape, bodies.robot, bodies.control):
            old.remove(part)
        for key in (2 * robot, 2 * robot + 1):  # chipmunk fills a gap with its last body
            order, at = self._order[was], self._local[key]
            last = order.pop()
            if last != key:
                order[at], self._local[last] = last, at
        for part in (bodies.robot, bodies.control, bodies.shape, *joints):
            new.add(part)
        for key in (2 * robot, 2 * robot + 1):
            self._local[key] = len(self._order[to])
            self._order[to].append(key)
        self.region[robot] = to

    # ------------------------------------------------------------------ stepping
    def _parallel(self, task: Callable[[int], None]) -> None:
        """Run ``task(k)`` for every region: region 0 on this thread, the others on the
        pool's; each region's thread CPU time is added to :attr:`thread_seconds`, the
        longest of them to :attr:`critical_seconds`."""
        if self._pool is None:
            self._pool = ThreadPoolExecutor(self.n_regions - 1, "physics-region")
            weakref.finalize(self, self._pool.shutdown, wait=False)
        spent = [0.0] * self.n_regions

        def timed(k: int) -> None:
            begun = time.thread_time()
            task(k)
            spent[k] = time.thread_time() - begun

        futures = [self._pool.submit(timed, k) for k in range(1, self.n_regions)]
        timed(0)
        for future in futures:
            future.result()
        self.thread_seconds = [a + b for a, b in zip(self.thread_seconds, spent, strict=True)]
        self.critical_seconds += max(spent)

    def advance(self, steps: int, dt: float) -> None:
        """Run ``steps`` physics steps of ``dt`` [s] in every space."""

        def run(k: int) -> None:
            step, handle = space_stepping(self.spaces[k])
            for _ in range(steps):
                step(handle, dt)

        self._parallel(run)

    def record(
        self, dt: float, indices: range, path: np.ndarray, turn_path: np.ndarray | None = None
    ) -> None:
        """:meth:`~warehouse_phys.physics.body_io.BodyRows.record_steps`: a physics step of
        ``dt`` [s] in every space for each of ``indices``, each robot's ``(x, y)`` [m] after it
        into ``path[index]`` (``(steps, N, 2)``), a turning robot's angle [rad] into
        ``turn_path[index]``."""

        def run(k: int) -> None:
            space, reader = self.spaces[k], self._readers[k]
            robots, rows = self._members[k], self._member_rows[k]
            step, handle = space_stepping(space)
            for index in indices:
                step(handle, dt)
                pose = reader.read(space)[rows]
                path[index, robots] = pose[:, :2]
                if turn_path is not None:
                    turn_path[index, robots] = pose[:, 2]

        self._parallel(run)

    # ------------------------------------------------------------------ reading, writing
    def robot_xy(self) -> np.ndarray:
        """Every robot's ``(x, y)`` [m], in robot order."""
        return self.states.read()[self.robot_rows, :2]

    def robot_angles(self) -> np.ndarray:
        """Every turning robot's angle [rad], in robot order."""
        return self.states.read()[self.robot_rows, 2]

    def write_positions(self, robot_xy: np.ndarray, control_xy: np.ndarray) -> None:
        """Place every robot and every control body [m] (a robot written where it is
        stays there exactly)."""
        states = self.states
        states.read()
        states.positions[self.robot_rows] = robot_xy
        states.positions[self.control_rows] = control_xy
        states.write()

    def write_poses(
        self,
        robot_xy: np.ndarray,
        robot_angles: np.ndarray,
        control_xy: np.ndarray,
        control_angles: np.ndarray,
    ) -> None:
        """Turning robots: place and turn every robot and control body [m, rad]."""
        states = self.states
        states.read()
        states.positions[self.robot_rows], states.angles[self.robot_rows] = robot_xy, robot_angles
        states.positions[self.control_rows] = control_xy
        states.angles[self.control_rows] = control_angles
        states.write()

    def snap(self, centre_xy: np.ndarray, angles: np.ndarray | None = None) -> None:
        """Every robot and its control body onto ``centre_xy`` [m] at rest (and onto
        ``angles`` [rad])."""
        states, rows = self.states, self.body_rows
        states.read()
        states.positions[rows] = np.concatenate((centre_xy, centre_xy))
        states.velocities[rows] = 0.0
        states.spins[rows] = 0.0
        if angles is not None:
            states.angles[rows] = np.concatenate((angles, angles))
        states.write()

    def renew(self, robot: int, xy: tuple[float, float], angle: float | None) -> None:
        """Make ``robot`` as newly built on ``xy`` [m] (facing ``angle``), in its space."""
        self.bodies[robot] = renew_robot(self.spaces[self.region[robot]], self.config,
                                         self.bodies[robot], xy, angle)  # fmt: skip

    def clear_time_step(self) -> None:
        """Forget every space's last time step (a world restarted whole)."""
        for space in self.spaces:
            clear_time_step(space)
