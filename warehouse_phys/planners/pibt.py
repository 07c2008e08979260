"""A fleet planner that never deadlocks: PIBT, priority inheritance with backtracking.

:class:`PIBT` plans one joint step at a time for every robot of a fleet (Okumura,
Machida, Defago and Tamura, "Priority inheritance with backtracking for iterative
multi-agent path finding", IJCAI 2019), written after pypibt, Okumura's own minimal
version: robots plan in order of priority; each takes the free neighbouring cell
closest to its goal, and a robot standing in the way *inherits* the planner's
priority and must move out of the way first (recursively), or the first robot
backtracks to its next candidate. :func:`pibt_policy` wraps it as a fleet policy
(the ``FleetPolicy`` of :mod:`warehouse_phys.rl.fleet_evaluation`).

The planner proposes and :mod:`warehouse_phys.world.traffic` grants: every joint action
it returns is granted in full by :func:`~warehouse_phys.world.traffic.resolve_moves`
(no two robots into one cell, no swaps, a robot enters an occupied cell only as
its occupant leaves, and without corner follows only straight behind it), so
the physics world's proof of the traffic rule covers its moves too.

Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk,
pygame nor PettingZoo; it reads the fleet's public arrays, never its internals.

Its length is one algorithm, PIBT, with its swap and its straight-line variant for
fleets without corner follows; its names are the paper's.
"""

from __future__ import annotations

import contextlib
from typing import TYPE_CHECKING, Any

import numpy as np

from warehouse_phys.planners.distances import DistanceMaps
from warehouse_phys.world.grid import ACTION_DELTAS, WarehouseGrid
from warehouse_phys.world.headings import (
    HEADING_MOVES,
    MOVE_HEADINGS,
    MOVE_MODELS,
    TurnAction,
    facing_move,
    quarter_turns,
    turn_towards,
    turning_moves,
)
from warehouse_phys.world.traffic import FLEET_ACTIONS, WAIT, neighbour_table

if TYPE_CHECKING:
    from warehouse_phys.envs.fleet import WarehouseFleetEnv
    from warehouse_phys.rl.fleet_evaluation import FleetPolicy

#: "No robot" / "not planned yet" in the planner's arrays.
NIL = -1
#: Without corner follows, how many robots of a line in the way are asked to leave it.
_MAX_ASKED = 8
#: Floors of at most this many cells keep every cell's exits as lists (faster checks).
_EXITS_LISTED = 200_000


class PIBT:
    """PIBT for one floor, stateful across the steps of an episode.

    ``plan(cells, goals, movable, present)`` returns every robot's action for the
    next joint step (0..3 a move, :data:`~warehouse_phys.world.traffic.WAIT`):

    - Robots plan in decreasing priority. A robot's priority grows by one each step it
      plans towards the same goal and falls back to its fractional tie-breaker (drawn
      once from ``seed``) when its goal changes, so a robot that waits long enough
      comes first (how PIBT reaches every goal: see below).
    - Candidates are the cells a move leads to and staying put, tried nearest to the
      goal first (exact distances from :class:`~warehouse_phys.planners.distances.DistanceMaps`,
      one look-up for every robot's five), among equals a cell nobody stands on (no
      push needed), then at random by a generator seeded with ``seed``.
    - With corner follows, PIBT's swap operation (Okumura 2023, LaCAM*'s PIBT): a robot
      whose best cell holds a robot that can only get out through its own cell (a
      corridor closed at the far end, a pocket left by parked robots) steps back, away
      from its goal, and pulls that robot into its cell, so the two pass each other
      where the corridor opens instead of facing each other for ever.
    - A robot that is not ``movable`` (parked on its delivered package) holds its cell
      and is never pushed; robots not ``present`` (gone from the floor) are ignored and
      wait.
    - **Every plan is granted by the traffic rule**: no two robots head for one cell,
      no two swap, a robot enters an occupied cell only as its occupant leaves. With
      ``corner_follows=False`` only straight behind it: a push moves the whole line of
      robots ahead one cell on in the same direction or is not made, no rotation
      (which always turns a corner) is planned, and a robot that cannot be pushed
      straight on steps aside instead, leaving its cell empty for the robot behind to
      enter on the next step (priority inheritance over two steps).

    What it promises beyond that is PIBT's reachability property: with corner follows,
    on a floor that joins every two neighbouring cells by a cycle (no dead ends), the
    robot of highest priority always moves to a cell nearer its goal, so every robot,
    once its turn at the top comes, reaches its goal: lifelong fleets on such floors
    never deadlock. What it does not promise: shortest paths or a bound on the sum of
    costs (it is a greedy, one-step planner); progress in dead ends, where robots must
    pass each other in a corridor closed at one end (a parked robot can make one): the
    swap operation resolves the common case of two, not every one; nor delivery in
    one-shot runs where a parked robot walls a package off (no planner can); and,
    without corner follows, PIBT's guarantee (the two-step inheritance is a
    heuristic: it resolves a robot blocking another against a wall, not every
    standoff; the swap operation is not made there).

    **Turning robots** (``moves="rotate"``, :mod:`warehouse_phys.world.headings`): PIBT
    over ``(cell, heading)``. The candidates are the neighbouring cells and staying, as
    above, ranked by a turn-aware distance: a cell costs the quarter turns to face it,
    the move, and its distance to the goal; staying costs a step more than the best
    cell (nothing on the goal). The recursion is PIBT's own (:meth:`_pibt`): a robot in
    the way inherits the priority and must move, or the planner backtracks. A robot
    whose planned cell is ahead drives forward; one whose planned cell is beside or
    behind it turns towards it (on the shorter side) and keeps that cell as its
    *commitment*: while it turns, it plans first each step, for that cell alone (the
    cell it needs stays free for it, and robots in it are pushed on); a commitment is
    dropped once reached, or when the robot moved, got another goal or could not keep
    the cell. A robot that stays turns towards its best candidate. The swap operation is
    not made (it would pull a robot backwards). Every plan passes the traffic rule before
    it is returned (a forward move behind a robot that turns instead of leaving waits),
    so it is granted in full; PIBT's reachability guarantee is not claimed for turning
    robots (no robot stayed stuck in the tests and benchmarks).

    Args:
        grid: The floor.
        distances: Distance maps of the floor (a fleet's ``env.distances``, shared so
            that each package's map is built once); a new one by default.
        corner_follows: Whether traffic grants corner follows (the fleet's
            ``corner_follows``).
        seed: Seeds the tie-breaks; the same seed and inputs give the same plans.
        moves: ``"grid"`` (four directions, default) or ``"rotate"`` (turning robots,
            whose :meth:`plan` takes their ``headings`` and returns turning actions).
    """

    def __init__(
        self,
        grid: WarehouseGrid,
        *,
        distances: DistanceMaps | None = None,
        corner_follows: bool = True,
        seed: int = 0,
        moves: str = "grid",
    ) -> None:
        if moves not in MOVE_MODELS:
            raise ValueError(f"moves must be one of {list(MOVE_MODELS)}, got {moves!r}")
        self.grid = grid
        self.distances = DistanceMaps(grid) if distances is None else distances
        self.corner_follows = bool(corner_follows)
        #: Whether the robots turn and drive forward (``moves="rotate"``).
        self.turning = moves == "rotate"
        #: Turning robots: the cell each is turning towards (:data:`NIL`: none), and the
        #: goal it was chosen for.
        self._committed = np.empty(0, dtype=np.int64)
        self._committed_goal = np.empty(0, dtype=np.int64)
        self.rng = np.random.default_rng(seed)
        self._table = neighbour_table(grid)
        cols = grid.cols
        #: The action of a move by its change of cell index.
        #: The action of a move by its change of cell index plus ``cols`` (WAIT for 0).
        self._action_of = [WAIT] * (2 * cols + 1)
        for action, (d_row, d_col) in enumerate(ACTION_DELTAS):
            self._action_of[d_row * cols + d_col + cols] = action
        self._priority: np.ndarray | None = None
        self._goals: np.ndarray | None = None
        #: Distances round the robots that hold their cells (parked), and those cells.
        self._around: DistanceMaps = self.distances
        self._held = np.empty(0, dtype=np.int64)
        #: Each cell's neighbouring cells a robot can enter (no shelf, no held cell).
        self._exits_of: list[list[int]] = []
        self._set_exits(self._held)
        #: Per plan: each robot's goal, and whether its distances ignore the held cells.
        self._goal_list: list[int] = []
        self._plain: np.ndarray = np.zeros(0, dtype=bool)

    def plan(
        self,
        cells: np.ndarray,
        goals: np.ndarray,
        movable: np.ndarray | None = None,
        present: np.ndarray | None = None,
        *,
        requests: dict[int, int] | None = None,
        headings: np.ndarray | None = None,
        candidate_values: np.ndarray | None = None,
    ) -> np.ndarray:
        """The next joint action: ``(N,)`` int64 in 0..4, from each robot's ``(row, col)``
        ``cells`` and ``goals`` (``(N, 2)``); ``movable`` and ``present`` default to all.
        Turning robots: their ``headings`` (``(N,)`` 0..3) too, and actions 0..3
        (:class:`~warehouse_phys.world.headings.TurnAction`).

        ``requests`` maps robots to the action someone else chose for them (a person at
        the keyboard): they plan first, with that move as their only candidate, so the
        robots in their way move aside; a request that cannot be met leaves the robot
        where it is.

        ``candidate_values`` (``(N, 5)`` float, optional) ranks a robot's candidates by
        other values than its distances to its goal, lower first (a guide: see
        :mod:`warehouse_phys.planners.guidance`): the cells of its four moves in action
        order, then its own cell; ``NaN`` where the planner's own distance is wanted.
        Everything else is as without it (ties, pushes, the swap operation's distances),
        so every plan is granted just the same.

        Raises:
            ValueError: if the number of robots changes between calls (start a new
                :class:`PIBT` for a new fleet), or turning robots come without headings.
        """
        cols = self.grid.cols
        cells = np.asarray(cells, dtype=np.int64).reshape(-1, 2)
        goals = np.asarray(goals, dtype=np.int64).reshape(-1, 2)
        n = len(cells)
        here = cells[:, 0] * cols + cells[:, 1]
        goal = goals[:, 0] * cols + goals[:, 1]
        present = np.ones(n, dtype=bool) if present is None else np.asarray(present, bool)
        movable = present.copy() if movable is None else np.asarray(movable, bool) & present
        if self.turning:
            if headings is None or np.shape(headings) != (n,):
                raise ValueError(f"turning robots need one heading each ({n}), got {headings!r}")
            headings = np.asarray(headings, dtype=np.int64)
        self._update_priorities(here, goal)
        distances = self._distances_round(np.sort(here[present & ~movable]))

        self._goal_list = goal.tolist()
        self._plain = np.isin(goal, self._held) if self._held.size else np.ones(n, dtype=bool)
        moving = np.flatnonzero(movable)
        if self.turning:
            self._commitments(here, goal, movable)
        ranked_of = self._ranked_candidates(
            here, goal, moving, present, distances, headings, candidate_values
        )

        here_list = here.tolist()
        plan = [NIL] * n
        # Who stands on each cell now, and who will after the step (NIL: nobody).
        occupied_now = [NIL] * (self.grid.rows * cols)
        occupied_next = [NIL] * (self.grid.rows * cols)
        for i in np.flatnonzero(present).tolist():
            occupied_now[here_list[i]] = i
        for i in np.flatnonzero(present & ~movable).tolist():  # parked: fixed obstacles
            plan[i] = here_list[i]
            occupied_next[here_list[i]] = i
        requested = {i: a for i, a in (requests or {}).items() if movable[i]}
        self._request(requested, here_list, headings, ranked_of)
        self._suspects = self._swap_suspects(here, present, moving, requested)
        by_priority = moving[np.argsort(-self._priority[moving], kind="stable")].tolist()
        first = list(requested)
        if self.turning:  # robots turning towards a cell plan first, for that cell alone
            committed = [i for i in by_priority if self._committed[i] != NIL and i not in requested]
            for i in committed:
                ranked_of[i] = [int(self._committed[i])]
            first += committed
        step_one = self._pibt if self.corner_follows or self.turning else self._pibt_straight
        for i in [*first, *by_priority]:
            if plan[i] == NIL:
                step_one(i, here_list, ranked_of, plan, occupied_now, occupied_next)
        if self.turning:
            return self._turning_actions(here, headings, goal, plan, ranked_of, present,
                                         movable, requested)  # fmt: skip

        actions = np.full(n, WAIT, dtype=np.int64)
        step = np.array(plan, dtype=np.int64)[moving] - here[moving] + cols
        actions[moving] = np.array(self._action_of, dtype=np.int64)[step]
        return actions

    def _request(
        self,
        requested: dict[int, int],
        here: list[int],
        headings: np.ndarray | None,
        ranked_of: list[Any],
    ) -> None:
        """Make each requested action its robot's one candidate."""
        for i, action in requested.items():
            if self.turning:  # forward: the cell ahead, a turn or a wait: its own cell
                ahead = int(self._table[here[i], HEADING_MOVES[headings[i]]])
                ranked_of[i] = [ahead if action == TurnAction.FORWARD else here[i]]
            else:
                ranked_of[i] = [int(self._table[here[i], action])]
                if action != WAIT and ranked_of[i][0] == here[i]:
                    ranked_of[i] = [here[i]]  # into a wall or shelf: it stays

    def _ranked_candidates(
        self,
        here: np.ndarray,
        goal: np.ndarray,
        moving: np.ndarray,
        present: np.ndarray,
        distances: DistanceMaps,
        headings: np.ndarray | None = None,
        values: np.ndarray | None = None,
    ) -> list[list[int] | None]:
        """Each moving robot's candidate cells, best first (``None`` for the others):
        nearest to its goal (turning robots: by :meth:`_count_turns`), then a cell nobody
        stands on now, then at random; cells it cannot reach its goal from are
        :data:`NIL`. ``values`` (``(N, 5)``, ``NaN``: the distance) replace the distances
        where given."""
        n, cols = len(here), self.grid.cols
        # Candidates of every moving robot, nearest to the goal first, in one look-up.
        candidates = self._table[here[moving]]  # (m, 5): the four moves, then staying
        targets = np.repeat(goal[moving], FLEET_ACTIONS).reshape(-1, FLEET_ACTIONS)
        if distances is self.distances:
            distance = distances.lookup(candidates, targets).astype(np.float64)
        else:  # round the held cells, but not towards one: that goal is on the plain floor
            distance = np.empty(candidates.shape, dtype=np.float64)
            onto_held = self._plain[moving]
            for rows, maps in ((onto_held, self.distances), (~onto_held, distances)):
                if rows.any():
                    distance[rows] = maps.lookup(candidates[rows], targets[rows])
        if values is not None:  # a guide's values where it gives them
            given = np.asarray(values, dtype=np.float64)[moving]
            distance = np.where(np.isnan(given), distance, given)
        blocked = candidates[:, :WAIT] == here[moving, None]  # a move into a wall or shelf
        distance[:, :WAIT][blocked] = np.inf  # UNREACHABLE cells stay last but one
        if headings is not None:
            distance = self._count_turns(distance, headings[moving], here[moving] == goal[moving])
        # Nearest first; among equals a cell nobody stands on now (no one to push),
        # then at random.
        occupied = np.zeros(self.grid.rows * cols, dtype=bool)
        occupied[here[present]] = True
        pushes = occupied[candidates] & (candidates != here[moving, None])
        tie_break = self.rng.random(distance.shape)
        order = np.lexsort((tie_break, pushes, distance), axis=1)
        ranked = np.take_along_axis(candidates, order, axis=1)
        ranked[np.take_along_axis(np.isinf(distance), order, axis=1)] = NIL
        self._first_choice = ranked[:, 0]
        ranked_of: list[list[int] | None] = [None] * n
        for i, row in zip(moving.tolist(), ranked.tolist(), strict=True):
            ranked_of[i] = row
        return ranked_of

    def _count_turns(
        self, distance: np.ndarray, headings: np.ndarray, at_goal: np.ndarray
    ) -> np.ndarray:
        """Turning robots' candidate values (``(m, 5)``: the four moves by grid action,
        then staying) from the cells' distances: a move costs the quarter turns to face it,
        the move and the cell's distance; staying costs a step more than the best move
        (0 on the goal)."""
        faces = MOVE_HEADINGS[np.arange(WAIT)]
        value = distance.copy()
        value[:, :WAIT] += quarter_turns(headings[:, None], faces[None, :]) + 1
        value[:, WAIT] = value[:, :WAIT].min(axis=1) + 1
        value[at_goal, WAIT] = 0.0
        return value

    def _commitments(self, here: np.ndarray, goal: np.ndarray, movable: np.ndarray) -> None:
        """Keep the cells turning robots are turning towards, dropping those reached, no
        longer next to the robot, or made for another goal."""
        n = len(here)
        if len(self._committed) != n:
            self._committed = np.full(n, NIL, dtype=np.int64)
            self._committed_goal = np.full(n, NIL, dtype=np.int64)
        committed = self._committed
        held = committed != NIL
        if held.any():
            beside = (self._table[here, :WAIT] == committed[:, None]).any(axis=1)
            keep = held & beside & (committed != here) & (self._committed_goal == goal) & movable
            committed[~keep] = NIL

    def _turning_actions(
        self,
        here: np.ndarray,
        headings: np.ndarray,
        goal: np.ndarray,
        plan: list[int],
        ranked_of: list[Any],
        present: np.ndarray,
        movable: np.ndarray,
        requested: dict[int, int],
    ) -> np.ndarray:
        """Turning robots' actions from the planned cells: forward where the planned cell
        is ahead; a turn towards it (on the shorter side) where it is beside or behind,
        and the robot keeps that cell as its next (a commitment, see the class); a robot
        that stays turns towards its best candidate. Passed through the traffic rule, so
        every action is granted."""
        n = len(here)
        moving = np.flatnonzero(movable)
        planned = np.array(plan, dtype=np.int64)
        stays = np.zeros(n, dtype=bool)
        stays[moving] = planned[moving] == here[moving]
        best = np.array([NIL if r is None else r[0] for r in ranked_of], dtype=np.int64)
        target = np.where(stays & (best != NIL), best, planned)  # staying: face the best cell
        target[~movable] = here[~movable]
        move = np.array(self._action_of, dtype=np.int64)[target - here + self.grid.cols]
        wanted = facing_move(move, headings)
        actions = turn_towards(headings, wanted)
        facing = (wanted == headings) & ~stays & movable
        actions[facing] = TurnAction.FORWARD
        for i, action in requested.items():
            if stays[i]:  # a turn or a wait as asked; a forward move that cannot be made waits
                actions[i] = action if action != TurnAction.FORWARD else TurnAction.WAIT
        grants = turning_moves(self.grid, here, headings, actions, ~movable & present,
                               corner_follows=self.corner_follows)  # fmt: skip
        actions[grants.refused] = TurnAction.WAIT
        commit = movable & ~stays & ~facing
        commit[list(requested)] = False
        commit |= facing & grants.refused & self.corner_follows  # it goes on the next step
        self._committed[commit] = planned[commit]
        self._committed_goal[commit] = goal[commit]
        self._committed[~commit] = NIL
        return actions

    def _distances_round(self, held: np.ndarray) -> DistanceMaps:
        """Distances on the floor with the ``held`` cells (parked robots, which never move
        again) as obstacles: without them a robot whose shortest path runs through a
        parked robot would wait beside it for ever. Rebuilt when the held cells change."""
        if not np.array_equal(held, self._held):
            self._held = held
            self._set_exits(held)
            self._around = self.distances
            if held.size:
                cols = self.grid.cols
                floor = np.where(self.grid.shelf_mask, "#", ".")
                floor[held // cols, held % cols] = "#"
                rows = ["".join(row) for row in floor.tolist()]
                with contextlib.suppress(ValueError):  # held cells that leave no floor
                    self._around = DistanceMaps(
                        WarehouseGrid.from_layout(rows), max_bytes=self.distances.max_bytes
                    )
        return self._around

    def _set_exits(self, held: np.ndarray) -> None:
        """The cells a robot can enter from each cell: moves that stay on the floor, off
        the shelves and off the ``held`` cells (the swap operation's graph)."""
        cells = np.arange(len(self._table))
        moves = self._table[:, :WAIT]
        enterable = moves != cells[:, None]
        if held.size:
            enterable &= ~np.isin(moves, held)
        self._exits_of = (
            [row[ok].tolist() for row, ok in zip(moves, enterable, strict=True)]
            if len(cells) <= _EXITS_LISTED
            else []
        )
        self._moves, self._enterable = moves, enterable
        self._exit_count = enterable.sum(axis=1)

    def _exits(self, cell: int) -> list[int]:
        if self._exits_of:
            return self._exits_of[cell]
        return self._moves[cell][self._enterable[cell]].tolist()

    def _distance(self, robot: int, cell: int) -> int:
        """Robot ``robot``'s distance from ``cell`` to its goal, on the same maps as its
        candidates."""
        maps = self.distances if self._plain[robot] else self._around
        return maps.distance(cell, self._goal_list[robot])

    def _swap_suspects(
        self, here: np.ndarray, present: np.ndarray, moving: np.ndarray, requested: dict
    ) -> list[bool]:
        """Which robots :meth:`_swap_partner` must look at: those whose first choice is a
        cell another robot stands on now with at most two ways out (the conditions of a
        swap that do not change during the step, tested for all robots at once), and
        those asked to move (their one candidate is the request)."""
        suspect = np.zeros(len(here), dtype=bool)
        occupant = np.full(len(self._table), NIL, dtype=np.int64)
        occupant[here[present]] = np.flatnonzero(present)
        best = self._first_choice
        chosen = best != NIL
        best = np.where(chosen, best, 0)
        suspect[moving] = (
            chosen
            & (best != here[moving])
            & (occupant[best] != NIL)
            & (self._exit_count[best] <= 2)
        )
        suspect[list(requested)] = True
        return suspect.tolist()

    def _swap_partner(
        self, i: int, here: list[int], ranked: list[int], plan: list[int], occupied_now: list[int]
    ) -> int:
        """The robot that ``i`` should let pass by stepping back (PIBT's swap operation,
        Okumura 2023), or :data:`NIL`: a robot ``j`` in ``i``'s way whose only way out runs
        through ``i``'s cell (a corridor closed at the far end, or one with no room to
        pass), where pushing ``j`` on can never succeed. ``i`` then steps away from its
        goal and pulls ``j`` into its cell; the two pass each other where the corridor
        opens."""
        best = next((cell for cell in ranked if cell != NIL), NIL)
        if best == NIL or best == here[i]:
            return NIL
        j = occupied_now[best]
        if (
            j != NIL
            and plan[j] == NIL
            and len(self._exits(best)) <= 2
            and self._swap_required(i, j, here[i], here[j])
            and self._swap_possible(here[j], here[i])
        ):
            return j
        return NIL

    def _swap_required(self, pusher: int, puller: int, v_pusher: int, v_puller: int) -> bool:
        """Whether ``pusher``, pushing ``puller`` on towards its own goal along a corridor,
        would run into the corridor's closed end short of its goal, and ``puller`` wants
        to come back out. (LaCAM*'s test also swaps when the push would carry ``puller``
        past its goal; on our floors that turned two robots in an aisle back and forth
        for ever, so a swap here is made only where pushing cannot work.)"""
        distance = self._distance
        for _ in range(len(self._table)):
            if distance(pusher, v_puller) >= distance(pusher, v_pusher):
                return False  # pushing on takes the pusher home
            ahead = [cell for cell in self._exits(v_puller) if cell != v_pusher]
            if len(ahead) >= 2:
                return False  # room to pass
            if not ahead:  # the closed end
                return distance(puller, v_pusher) < distance(puller, v_puller)
            v_pusher, v_puller = v_puller, ahead[0]
        return False

    def _swap_possible(self, v_pusher: int, v_puller: int) -> bool:
        """Whether the robot on ``v_puller``, backing away from ``v_pusher`` along the
        corridor, reaches a cell with room for the other to pass."""
        origin = v_pusher
        for _ in range(len(self._table)):
            if v_puller == origin:
                return False  # round a loop
            behind = [cell for cell in self._exits(v_puller) if cell != v_pusher]
            if len(behind) >= 2:
                return True
            if not behind:
                return False
            v_pusher, v_puller = v_puller, behind[0]
        return False

    def _update_priorities(self, here: np.ndarray, goal: np.ndarray) -> None:
        """Grow the robots' priorities (:func:`grow_priorities`)."""
        self._priority, self._goals = grow_priorities(self._priority, self._goals, here, goal,
                                                      self.rng)  # fmt: skip

    def _pibt(
        self,
        root: int,
        here: list[int],
        ranked_of: list[Any],
        plan: list[int],
        occupied_now: list[int],
        occupied_next: list[int],
    ) -> None:
        """PIBT's recursive ``funcPIBT`` from robot ``root``, with an explicit stack (a
        chain of pushed robots can be longer than Python's recursion allows): the
        planner of a fleet whose robots may follow each other round corners."""
        # Each frame: [robot, its candidates, the position of the next one to try, the
        # robot it pulls into its cell once it moves (the swap operation) or NIL].
        suspects = self._suspects  # the others' frames are built inline: most robots
        stack = [self._frame(root, here, ranked_of, plan, occupied_now)]
        child_planned = None  # the outcome of the frame just popped
        while stack:
            frame = stack[-1]
            i, candidates, position, partner = frame
            if child_planned is not None:
                if child_planned:  # the pushed robot got out of the way: done
                    self._pull(i, partner, here, plan, occupied_next)
                    stack.pop()
                    child_planned = True
                    continue
                child_planned = None  # it stayed in the cell: try the next candidate
            while position < len(candidates):
                cell = candidates[position]
                position += 1
                if cell == NIL or occupied_next[cell] != NIL:
                    continue
                j = occupied_now[cell]
                if j != NIL and j != i and plan[j] == here[i]:
                    continue  # a swap
                plan[i] = cell
                occupied_next[cell] = i
                if j != NIL and j != i and plan[j] == NIL:  # j inherits: it must move
                    frame[2] = position
                    stack.append(
                        self._frame(j, here, ranked_of, plan, occupied_now)
                        if suspects[j]
                        else [j, ranked_of[j], 0, NIL]
                    )
                    break
                self._pull(i, partner, here, plan, occupied_next)
                stack.pop()
                child_planned = True
                break
            else:  # every candidate failed: stay (the caller backtracks)
                plan[i] = here[i]
                occupied_next[here[i]] = i
                stack.pop()
                child_planned = False

    def _frame(
        self,
        i: int,
        here: list[int],
        ranked_of: list[Any],
        plan: list[int],
        occupied_now: list[int],
    ) -> list[Any]:
        """A stack frame of :meth:`_pibt` for robot ``i``: its candidates, reversed (away
        from its goal first) when it must let a robot pass (:meth:`_swap_partner`)."""
        candidates = ranked_of[i]
        if self.turning:  # no swap operation: it would pull a robot backwards
            return [i, candidates, 0, NIL]
        if not self._suspects[i]:
            return [i, candidates, 0, NIL]
        partner = self._swap_partner(i, here, candidates, plan, occupied_now)
        if partner != NIL:
            candidates = candidates[::-1]
        return [i, candidates, 0, partner]

    @staticmethod
    def _pull(
        i: int, partner: int, here: list[int], plan: list[int], occupied_next: list[int]
    ) -> None:
        """The swap operation's second half: ``i`` has moved off its cell, and ``partner``,
        if not planned yet, follows it there."""
        if partner != NIL and plan[partner] == NIL and occupied_next[here[i]] == NIL:
            plan[partner] = here[i]
            occupied_next[here[i]] = partner

    def _pibt_straight(
        self,
        i: int,
        here: list[int],
        ranked_of: list[Any],
        plan: list[int],
        occupied_now: list[int],
        occupied_next: list[int],
    ) -> None:
        """PIBT for a fleet without corner follows, from robot ``i``.

        A robot may enter an occupied cell only as its occupant leaves straight ahead,
        so a push is a line: the robots ahead of ``i`` in the direction of its move all
        step forward together, or the move is not taken. Robots that a push could not
        move are left unplanned (free to go their own way later in the step), not
        pinned to their cells as in PIBT's backtracking. When ``i`` ends up staying put
        because such a line stood on a cell nearer its goal, the line's robots, nearest
        first, inherit ``i``'s priority and the first of them that can leave its cell
        (any way but back) does, and its cell stays empty: on the next step the line
        closes up and ``i`` moves on. Priority inheritance over two steps, where corner
        follows do it in one.

        The swap operation is made straight, for a robot in a pocket (a cell with one way
        out): a robot ``i`` that must let it out (:meth:`_swap_partner`) backs away from
        it in the line of the two, pushing the line behind it, and pulls it on after it.
        """
        partner = (
            self._swap_partner(i, here, ranked_of[i], plan, occupied_now)
            if self._suspects[i]
            else NIL
        )
        if partner != NIL and len(self._exits(here[partner])) == 1:  # a pocket
            away = int(
                self._table[here[i], self._action_of[here[i] - here[partner] + self.grid.cols]]
            )
            if away != here[i]:
                own = ranked_of[i]
                ranked_of[i] = [away]
                line = self._move_straight(i, here, ranked_of, plan, occupied_now, occupied_next)
                ranked_of[i] = own
                if line is None:
                    self._pull(i, partner, here, plan, occupied_next)
                    return
        line = self._move_straight(i, here, ranked_of, plan, occupied_now, occupied_next)
        if line is None:
            return
        plan[i] = here[i]
        occupied_next[here[i]] = i
        for j in line[:_MAX_ASKED]:
            occupied_next[here[j]] = i  # kept empty: j may not stay
            if self._move_straight(j, here, ranked_of, plan, occupied_now, occupied_next) is None:
                return
            occupied_next[here[j]] = NIL

    def _move_straight(
        self,
        i: int,
        here: list[int],
        ranked_of: list[Any],
        plan: list[int],
        occupied_now: list[int],
        occupied_next: list[int],
    ) -> list[int] | None:
        """Plan ``i``'s best candidate that traffic grants without corner follows, pushing
        the line ahead of it straight on, and return None; or, when staying is the best
        left (nothing is planned then), the robots in the way of the first better cell
        that could not be reached, nearest first (perhaps none)."""
        table, action_of, cols = self._table, self._action_of, self.grid.cols
        blocked_by: list[int] = []
        for cell in ranked_of[i]:
            if cell == NIL or occupied_next[cell] != NIL:
                continue
            if cell == here[i]:
                break  # staying is the best that is left
            step = cell - here[i]
            action = action_of[step + cols]
            line, ahead = [], cell  # the unplanned robots to push, and the cell reached
            while True:
                if occupied_next[ahead] != NIL:
                    goes = False  # someone stays or arrives there
                    break
                j = occupied_now[ahead]
                if j == NIL:
                    goes = True
                    break
                if plan[j] != NIL:  # planned already: it must leave straight ahead
                    goes = plan[j] - ahead == step
                    break
                line.append(j)
                onward = int(table[ahead, action])
                if onward == ahead:
                    goes = False  # pushed into a wall or a shelf
                    break
                if len(self._exits(onward)) == 1 and onward != self._goal_list[j]:
                    goes = False  # pushed into a pocket it would have to back out of
                    break
                ahead = onward
            if not goes:
                if not blocked_by:
                    blocked_by = line
                continue
            plan[i] = cell
            occupied_next[cell] = i
            for j in line:
                onward = here[j] + step
                plan[j] = onward
                occupied_next[onward] = j
            return None
        return blocked_by


def grow_priorities(
    priority: np.ndarray | None,
    goals_before: np.ndarray | None,
    here: np.ndarray,
    goal: np.ndarray,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """PIBT's priorities after one more step: each robot still on its way to the same goal
    gains one; a robot with a new goal (or on its goal) falls back to its tie-breaker, the
    fraction drawn from ``rng`` on the first step (``priority`` None). Returns the
    priorities (updated in place) and the goals to pass next time.

    Raises:
        ValueError: if the number of robots changed.
    """
    n = len(here)
    if priority is None:
        return rng.random(n), goal.copy()
    if len(priority) != n:
        raise ValueError(
            f"this planner planned for {len(priority)} robots, now {n}: "
            "use a new planner for a new fleet"
        )
    fresh = (goal != goals_before) | (here == goal)
    priority[fresh] -= np.floor(priority[fresh])
    priority[~fresh] += 1
    return priority, goal.copy()


def pibt_policy(seed: int = 0) -> FleetPolicy:
    """A fleet policy (``FleetPolicy``) that plans with :class:`PIBT`: stateful across
    the steps of an episode, started afresh when the environment resets (``env.steps``
    back at 0) or another environment calls it. It reads the fleet's public state only:
    ``grid``, ``robot_cells``, ``package_cells``, ``parked``, ``on_floor``, ``steps``,
    ``corner_follows``, ``distances``, and for turning robots ``moves`` and
    ``robot_headings``."""
    state: dict[str, Any] = {"env": None, "planner": None, "index": {}}

    def policy(
        env: WarehouseFleetEnv,
        observations: dict[str, np.ndarray],
        infos: dict[str, dict[str, Any]],
    ) -> dict[str, int]:
        if state["env"] is not env or env.steps == 0:
            state["env"] = env
            state["planner"] = PIBT(env.grid, distances=env.distances,
                                    corner_follows=env.corner_follows, seed=seed,
                                    moves=getattr(env, "moves", "grid"))  # fmt: skip
            state["index"] = {agent: i for i, agent in enumerate(env.possible_agents)}
        planner: PIBT = state["planner"]
        actions = planner.plan(
            env.robot_cells,
            env.package_cells,
            ~env.parked & env.on_floor,
            env.on_floor,
            headings=getattr(env, "robot_headings", None),
        ).tolist()
        index = state["index"]
        return {agent: actions[index[agent]] for agent in env.agents}

    return policy
