"""Delays replayed from a run's record: the same delays, tick for tick, as another run had.

League of Robot Runners 2026 draws its delays from ``std::mt19937`` seeded by the
instance's ``delayConfig``; :class:`~warehouse_phys.execution.delays.DelayGenerator`
follows its model but not its random stream, so the two never delay the same robots at
the same ticks. To set one executor beside another on the same delays, a run replays the
``delayIntervals`` that an official run wrote (per robot its ``[start, end]`` pairs: the
robot is delayed at ticks ``start .. end - 1``). :class:`DelayReplay` is a drop-in for
the generator (``next_tick``, ``remaining``, ``tick``, ``intervals``, ``intervals_json``):
at the end of a run as long as the record, its intervals are the record's, every one.

The kit's generator counts its own ticks, one a simulated tick and one more each tick an
entry's executor overran its time (``Simulator::move``'s timeout waits); a record of a
run without timeouts (``numEntryTimeouts`` 0 and no "timeout" in the kit's log) has its
ticks equal to the simulation's. Like :mod:`warehouse_phys.world.grid`, this module
imports neither gymnasium, pymunk nor pygame.
"""

from __future__ import annotations

import numpy as np

from warehouse_phys.execution.delays import DelayIntervals
from warehouse_phys.execution.ticks import MAX_ROBOTS, check_whole


class DelayReplay:
    """Recorded delays, a tick at a call (see the module).

    Args:
        intervals: One list a robot of ``[start, end]`` pairs (LoRR's ``delayIntervals``):
            ``0 <= start < end``, each robot's in order and apart (an end may equal the
            next start, as the kit draws them).
        ticks: The ticks the record covers; :meth:`next_tick` refuses to go past them
            (``None``: no bound, no delays after the last interval).
        source: Where the record comes from (a file's name), for reports.

    Raises:
        ValueError, TypeError: one line naming the robot and the pair, for intervals that
            are not that.
    """

    def __init__(
        self, intervals: list[list[list[int]]], ticks: int | None = None, *,
        source: str | None = None,
    ) -> None:  # fmt: skip
        if not isinstance(intervals, list):
            raise TypeError(f"intervals must be one list a robot, got {type(intervals).__name__}")
        self.n_robots = check_whole("robots", len(intervals), 0, MAX_ROBOTS)
        self.ticks = None if ticks is None else check_whole("ticks", ticks, 0, 10**9)
        #: Where the record comes from, ``None`` if not said.
        self.source = source
        robots, starts, ends = [], [], []
        for robot, pairs in enumerate(intervals):
            last = 0
            for pair in pairs:
                ok = (isinstance(pair, (list, tuple)) and len(pair) == 2
                      and all(isinstance(v, (int, np.integer)) and not isinstance(v, bool)
                              for v in pair))  # fmt: skip
                if not ok or not last <= pair[0] < pair[1]:
                    raise ValueError(
                        f"intervals of robot {robot}: {pair!r} is not a [start, "
                        f"end] pair in order (0 <= start < end, after {last})"
                    )
                robots.append(robot)
                starts.append(int(pair[0]))
                ends.append(int(pair[1]))
                last = int(pair[1])
        order = np.lexsort((np.array(robots, np.int64), np.array(starts, np.int64)))
        self._robot = np.array(robots, dtype=np.int64)[order]
        self._start = np.array(starts, dtype=np.int64)[order]
        self._end = np.array(ends, dtype=np.int64)[order]
        self._remaining = np.zeros(self.n_robots, dtype=np.int64)
        self._tick = 0
        self._used = 0  # intervals started so far

    def rewind(self) -> None:
        """Back to tick 0, nothing replayed."""
        self._remaining[:] = 0
        self._tick = 0
        self._used = 0

    @property
    def tick(self) -> int:
        """How many ticks have been replayed: the next tick's number."""
        return self._tick

    @property
    def remaining(self) -> np.ndarray:
        """Ticks of delay each robot has left, this tick included (read-only view)."""
        view = self._remaining.view()
        view.flags.writeable = False
        return view

    def next_tick(self) -> np.ndarray:
        """Replay tick :attr:`tick`; returns which robots are delayed at it, a fresh
        ``(n_robots,)`` bool array.

        Raises:
            ValueError: past the record's ``ticks``.
        """
        if self.ticks is not None and self._tick >= self.ticks:
            raise ValueError(f"the recorded delays cover {self.ticks:,} ticks; tick "
                             f"{self._tick:,} is past them")  # fmt: skip
        remaining = self._remaining
        np.subtract(remaining, 1, out=remaining, where=remaining > 0)
        stop = int(np.searchsorted(self._start, self._tick, side="right"))
        now = slice(self._used, stop)
        remaining[self._robot[now]] = self._end[now] - self._start[now]
        self._used = stop
        self._tick += 1
        return remaining > 0

    def intervals(self) -> DelayIntervals:
        """Every delay replayed so far (fresh arrays), ordered by start tick, then robot."""
        used = slice(0, self._used)
        return DelayIntervals(self._robot[used].copy(), self._start[used].copy(),
                              self._end[used].copy())  # fmt: skip

    def intervals_json(self) -> list[list[list[int]]]:
        """LoRR's ``delayIntervals`` of the delays replayed so far: one list a robot of its
        ``[start, end]`` pairs, in order of start."""
        robot, start, end = self.intervals()
        order = np.argsort(robot, kind="stable")
        pairs = np.stack([start[order], end[order]], axis=1).tolist()
        bounds = np.searchsorted(robot[order], np.arange(self.n_robots + 1)).tolist()
        return [pairs[bounds[i] : bounds[i + 1]] for i in range(self.n_robots)]
