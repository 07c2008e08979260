"""A fleet planner that never deadlocks: PIBT, priority inheritance with backtracking.

:class:`PIBT` plans one joint step at a time for every robot of a fleet (Okumura,
Machida, Defago and Tamura, "Priority inheritance with backtracking for iterative
multi-agent path finding", IJCAI 2019), written after pypibt, Okumura's own minimal
version: robots plan in order of priority; each takes the free neighbouring cell
closest to its goal, and a robot standing in the way *inherits* the planner's
priority and must move out of the way first (recursively), or the first robot
backtracks to its next candidate. Its policy, ``pibt_policy``, is in
:mod:`warehouse_phys.rl.fleet_planners` (still found here, on demand).

The planner proposes and :mod:`warehouse_phys.world.traffic` grants: every joint action
it returns is granted in full by :func:`~warehouse_phys.world.traffic.resolve_moves`
(no two robots into one cell, no swaps, a robot enters an occupied cell only as
its occupant leaves, and without corner follows only straight behind it), so
the physics world's proof of the traffic rule covers its moves too.

Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk,
pygame nor PettingZoo; it reads the fleet's public arrays, never its internals.

Its parts each have a module of their own: the floor round parked robots
(:mod:`~warehouse_phys.planners.pibt.floor`), the swap operation
(:mod:`~warehouse_phys.planners.pibt.swaps`), the straight-line pushes of fleets without
corner follows (:mod:`~warehouse_phys.planners.pibt.straight`), turning robots' actions
(:mod:`~warehouse_phys.planners.pibt.turning`) and the priorities
(:mod:`~warehouse_phys.planners.pibt.priorities`); the recursion and the names are the
paper's. :mod:`~warehouse_phys.planners.pibt.stalls` says when a planner over operations
should hand its fleet over to PIBT.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from warehouse_phys.planners.distances import DistanceMaps
from warehouse_phys.planners.pibt.floor import NIL, PlanningFloor
from warehouse_phys.planners.pibt.priorities import grow_priorities
from warehouse_phys.planners.pibt.straight import StraightPushes
from warehouse_phys.planners.pibt.swaps import SwapOperation, pull
from warehouse_phys.planners.pibt.turning import Commitments, count_turns
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.headings import HEADING_MOVES, MOVE_MODELS, TurnAction
from warehouse_phys.world.traffic import FLEET_ACTIONS, WAIT


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
    cell (nothing on the goal). The recursion is PIBT's own (``_pibt``): a robot in
    the way inherits the priority and must move, or the planner backtracks. A robot
    whose planned cell is ahead drives forward; one whose planned cell is beside or
    behind it turns towards it (on the shorter side) and keeps that cell as its
    *commitment*: while it turns, it plans first each step, for that cell alone (the
    cell it needs stays free for it, and robots in it are pushed on); a commitment is
    dropped once reached, or when the robot moved, got another goal or could not keep
    the cell. A robot that stays turns towards its best candidate. The swap operation is
    made as above, over several steps: the robot that must let another out of a dead
    end turns away and backs off (its new cell its commitment), and the other, pulled
    into its cell, turns to face it and follows as it leaves. Without it, a robot whose
    goal lies in a dead end held by another waited at the mouth for ever, and the
    robots behind them piled up into a jam (on a 32 x 32 random floor with 400 robots,
    85 % of the actions were waits by step 1,000). Every plan passes the traffic rule before
    it is returned (a forward move behind a robot that turns instead of leaving waits),
    so it is granted in full; PIBT's reachability guarantee is not claimed for turning
    robots (a robot that must turn before it can make way holds up those behind it).

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
        self.rng = np.random.default_rng(seed)
        #: The floor's tables, and the cells parked robots hold with the distances round them.
        self._floor = PlanningFloor(grid, self.distances)
        self._swap = SwapOperation(self._floor)
        self._straight = StraightPushes(self._floor, self._swap)
        #: Turning robots: the cell each is turning towards.
        self._commitments = Commitments(self._floor, self.corner_follows)
        self._priority: np.ndarray | None = None
        self._goals: np.ndarray | None = None

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
        distances = self._floor.distances_round(np.sort(here[present & ~movable]))

        self._floor.aim(goal)
        moving = np.flatnonzero(movable)
        if self.turning:
            self._commitments.keep(here, goal, movable)
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
        self._suspects = self._swap.suspects(here, present, moving, requested, self._first_choice)
        by_priority = moving[np.argsort(-self._priority[moving], kind="stable")].tolist()
        first = list(requested)
        if self.turning:  # robots turning towards a cell plan first, for that cell alone
            towards = self._commitments.cell
            committed = [i for i in by_priority if towards[i] != NIL and i not in requested]
            for i in committed:
                ranked_of[i] = [int(towards[i])]
            first += committed
        for i in [*first, *by_priority]:
            if plan[i] != NIL:
                continue
            if self.corner_follows or self.turning:
                self._pibt(i, here_list, ranked_of, plan, occupied_now, occupied_next)
            else:  # pushes in straight lines
                self._straight.plan_robot(i, here_list, ranked_of, plan, occupied_now,
                                          occupied_next, self._suspects)  # fmt: skip
        if self.turning:
            return self._commitments.actions(here, headings, goal, plan, ranked_of, present,
                                             movable, requested)  # fmt: skip

        actions = np.full(n, WAIT, dtype=np.int64)
        step = np.array(plan, dtype=np.int64)[moving] - here[moving] + cols
        actions[moving] = np.array(self._floor.action_of, dtype=np.int64)[step]
        return actions

    def forget_commitments(self, robots: np.ndarray) -> None:
        """Turning robots: drop the cells ``robots`` were turning towards, for a plan that
        something after PIBT changed (a repair: :mod:`warehouse_phys.planners.repair`)."""
        if self.turning and len(self._commitments.cell):
            self._commitments.cell[robots] = NIL

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
                ahead = int(self._floor.table[here[i], HEADING_MOVES[headings[i]]])
                ranked_of[i] = [ahead if action == TurnAction.FORWARD else here[i]]
            else:
                ranked_of[i] = [int(self._floor.table[here[i], action])]
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
        nearest to its goal (turning robots: by :func:`count_turns`), then a cell nobody
        stands on now, then at random; cells it cannot reach its goal from are
        :data:`NIL`. ``values`` (``(N, 5)``, ``NaN``: the distance) replace the distances
        where given."""
        n, cols = len(here), self.grid.cols
        # Candidates of every moving robot, nearest to the goal first, in one look-up.
        candidates = self._floor.table[here[moving]]  # (m, 5): the four moves, then staying
        targets = np.repeat(goal[moving], FLEET_ACTIONS).reshape(-1, FLEET_ACTIONS)
        given = None if values is None else np.asarray(values, dtype=np.float64)[moving]
        # Distances only for the robots the guide leaves (a goal's map costs a search).
        wanted = None if given is None else np.isnan(given).any(axis=1)
        if wanted is None or wanted.all():
            distance = self._distances(candidates, targets, moving, distances)
        else:
            distance = np.zeros(candidates.shape, dtype=np.float64)
            distance[wanted] = self._distances(candidates[wanted], targets[wanted],
                                               moving[wanted], distances)  # fmt: skip
        if given is not None:  # a guide's values where it gives them
            distance = np.where(np.isnan(given), distance, given)
        blocked = candidates[:, :WAIT] == here[moving, None]  # a move into a wall or shelf
        distance[:, :WAIT][blocked] = np.inf  # UNREACHABLE cells stay last but one
        if headings is not None:
            distance = count_turns(distance, headings[moving], here[moving] == goal[moving])
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
        rows = ranked.tolist()
        if len(moving) == n:  # every robot moves: ``moving`` is 0..n-1
            return rows
        ranked_of: list[list[int] | None] = [None] * n
        for i, row in zip(moving.tolist(), rows, strict=True):
            ranked_of[i] = row
        return ranked_of

    def _distances(
        self, candidates: np.ndarray, targets: np.ndarray, moving: np.ndarray,
        distances: DistanceMaps,
    ) -> np.ndarray:  # fmt: skip
        """The moves from ``candidates`` to ``targets`` (float64) of the ``moving`` robots
        they belong to: on ``distances`` (round the held cells), but towards a held cell
        on the plain floor's."""
        if distances is self.distances:
            return distances.lookup(candidates, targets).astype(np.float64)
        distance = np.empty(candidates.shape, dtype=np.float64)
        onto_held = self._floor.plain[moving]
        for rows, maps in ((onto_held, self.distances), (~onto_held, distances)):
            if rows.any():
                distance[rows] = maps.lookup(candidates[rows], targets[rows])
        return distance

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
                    pull(i, partner, here, plan, occupied_next)
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
                pull(i, partner, here, plan, occupied_next)
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
        from its goal first) when it must let a robot pass (:meth:`SwapOperation.partner
        <warehouse_phys.planners.pibt.swaps.SwapOperation.partner>`)."""
        candidates = ranked_of[i]
        if not self._suspects[i]:
            return [i, candidates, 0, NIL]
        partner = self._swap.partner(i, here, candidates, plan, occupied_now)
        if partner != NIL:
            candidates = candidates[::-1]
        return [i, candidates, 0, partner]


def __getattr__(name: str) -> Any:
    if name == "pibt_policy":  # moved to the planners' policies (rl), a floor above
        from warehouse_phys.rl.fleet_planners import pibt_policy

        return pibt_policy
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
