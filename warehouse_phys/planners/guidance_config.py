"""The guidance's configuration: how guide paths are priced, refreshed and bounded.

:class:`GuidanceConfig` holds every knob of
:class:`~warehouse_phys.planners.traffic_guidance.TrafficGuidance` (and so of
:class:`~warehouse_phys.planners.guidance.GuidedPIBT` and of the guided planners by name,
:mod:`warehouse_phys.rl.fleet_planners`), a field each with its unit, and refuses a value
out of range when it is made. What each does to the guide paths is the guidance's module
docstring (:mod:`warehouse_phys.planners.guidance`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

#: Most phantom guide paths a lane may carry (``turn_lane_paths``); far fewer already
#: price driving against a lane above any way round.
MAX_LANE_PATHS = 1000
#: Guide paths a batch of the first step searches by default (``first_search_batch``):
#: enough for every thread of a machine of a few cores to have several.
FIRST_SEARCH_BATCH = 64
#: A batch of the first step is at most this share of that step's searches: each path
#: then misses at most a hundredth of the paths searched before it. Batches of 64 cost
#: 192 robots on the 33 x 46 Kiva floor 4 % of their deliveries (a third of the fleet
#: searched blind to each other) and 10,000 robots on MR23-I-06 and MR23-I-10 none
#: measurable; 192 robots' first searches take milliseconds, one at a time.
FIRST_BATCH_SHARE = 1 / 100
#: Most threads that search a batch (``workers``).
MAX_WORKERS = 64
#: Most threads by default: a first step's batch of 64 gives 8 threads 8 searches each,
#: and each thread holds search buffers of its own (28 bytes a free cell).
DEFAULT_MAX_WORKERS = 8


def default_workers() -> int:
    """The guide searches' threads by default: the cores this process may run on (its
    CPU affinity, which ``taskset`` or a container's cpuset may narrow; a CPU quota does
    not), at most :data:`DEFAULT_MAX_WORKERS`."""
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # no affinity on this system (macOS)
        cores = os.cpu_count() or 1
    return max(1, min(cores, DEFAULT_MAX_WORKERS))


@dataclass(frozen=True)
class GuidanceConfig:
    """How :class:`~warehouse_phys.planners.traffic_guidance.TrafficGuidance` prices and refreshes
    guide paths, each field checked when the configuration is made.

    Raises:
        ValueError: for a weight, cost, count or bound out of its range.
        TypeError: for a lane count, ``reroute`` or a batch size that is not an int.
    """

    #: Cost of a move per guide path leaving the cell it enters [moves].
    vertex_weight: float = 0.5
    #: Cost of a move per product of the paths along it (itself included) and against it.
    contraflow_weight: float = 1.0
    #: The A*'s heuristic is this times the Manhattan distance (1: the cheapest path).
    heuristic_weight: float = 1.0
    #: Cost of a quarter turn in a turning robot's guide path [moves] (None: its guide
    #: path is searched as a four-direction robot's).
    turn_cost: float | None = 1.0
    #: A turn holds up the robots behind it: a quarter turn at a cell costs ``turn_cost``
    #: times (1 + this times the guide paths leaving the cell; 0: ``turn_cost`` alone).
    turn_traffic_weight: float = 0.5
    #: ``contraflow_weight`` for a turning robot's guide path (None: the same): a turning
    #: robot that meets another head-on must turn round (two turns) or wait, so paths
    #: against the traffic cost it more.
    turn_contraflow_weight: float | None = 4.0
    #: One-way lanes for turning robots: phantom guide paths laid along the lane of every
    #: cell of a one-cell-wide corridor (:func:`~warehouse_phys.planners.lanes.one_way_lanes`),
    #: so that a guide path against a lane pays the contraflow of this many paths (0: no
    #: lanes).
    turn_lane_paths: int = 2
    #: Lanes over the whole floor for turning robots, open floor included: phantom guide
    #: paths laid along each cell's east-west and north-south lanes
    #: (:func:`~warehouse_phys.planners.lanes.floor_lanes`), seen by the contraflow of a
    #: search alone, so that a guide path against a lane pays the contraflow of this many
    #: paths (0: none).
    floor_lane_paths: int = 0
    #: Lanes learned from the fleet's own traffic, for turning robots
    #: (:class:`~warehouse_phys.planners.lanes.learned.TrafficLanes`): phantom guide
    #: paths along the way most of a cell's traffic goes, seen by the contraflow alone
    #: (0: none).
    learned_lane_paths: int = 0
    #: Steps between two updates of the learned lanes.
    learn_period: int = 50
    #: Learned lanes to start from (:meth:`TrafficLanes.save
    #: <warehouse_phys.planners.lanes.learned.TrafficLanes.save>`'s file, learned on
    #: the same floor); None: none.
    learned_lanes_file: str | None = None
    #: Whether robots follow their guide paths (else distances with a flow tie-break).
    follow: bool = True
    #: Robots whose guide path is searched anew each step besides those that need one.
    refresh: int = 0
    #: How many cells of its guide path ahead of a robot are looked at [cells].
    window: int = 8
    #: Whether a robot pushed aside or back, one move off its guide path, rejoins it
    #: (else a new search; a robot beside a cell further along always rejoins).
    rejoin: bool = False
    #: A robot pushed off its guide path with more than twice this many cells of it left
    #: searches only to the path's cell this many past where it stood, and keeps the path
    #: from there [cells] (0: a new search to the goal). On 2024 GAME's long paths the
    #: steps cost a fifth for the same tasks; on SORTATION twice as much, for fewer
    #: (the documentation's LoRR page, ``docs/lorr.md``).
    reroute: int = 0
    #: Guide paths searched as one batch, against the same flow (1: each search sees every
    #: path before it). A batch's paths depend on the batch alone, so a step's plans are
    #: the same for any number of ``workers``.
    search_batch: int = 1
    #: The first step's batches (None: ``search_batch``), when every robot needs its first
    #: guide path, so that ``workers`` threads share that step's searches while later
    #: steps search ``search_batch`` at a time; a batch is at most
    #: :data:`FIRST_BATCH_SHARE` of the step's searches (so fleets under 200 robots
    #: search one at a time). Its paths differ from one-at-a-time searches', and so does
    #: every plan after; with 10,000 turning robots the runs finished as many (MR23-I-10:
    #: 37.35 errands a step over 5,000 steps either way; MR23-I-06: 38.25 against 38.27),
    #: and two threads took the first step from 87 s to 50 s of wall time on MR23-I-06
    #: (the documentation's LoRR page, ``docs/lorr.md``).
    first_search_batch: int | None = FIRST_SEARCH_BATCH
    #: Threads that search a batch (:mod:`~warehouse_phys.planners.guide_searches`):
    #: by default the cores this process may run on (:func:`default_workers`). The plans
    #: are the same for any number.
    workers: int = field(default_factory=default_workers)
    #: Most guide-path searches in one step (None: no bound).
    max_searches: int | None = None
    #: Most guide-path searches in each step after the first (None: ``max_searches``
    #: bounds them too). Robots left over are searched first the next step, and are
    #: valued by PIBT's distances until then. A count, so the plans are the same on any
    #: machine: on MR23-I-06 the second step searches 325 robots pushed off their first
    #: paths (3.3 s of CPU) where later steps search tens.
    later_max_searches: int | None = None
    #: Most cells the guide-path searches of each step after the first may expand
    #: together (None: no bound), checked before each batch (a batch begun finishes).
    #: The cells a search expands are its work: a bound on them bounds a step's searches
    #: about as a time limit would, on any map (a search takes under 1 ms on one and
    #: over 10 ms on another), and is the same on any machine. Robots left over are
    #: treated as ``later_max_searches`` leaves them. The repairing planners bound it by
    #: default (:data:`~warehouse_phys.planners.named.LATER_MAX_EXPANDED`).
    later_max_expanded: int | None = None
    #: Most wall-clock time of one step's searches [s] (None: no bound), checked before
    #: each batch of searches: the robots left get PIBT's distances (and the run may
    #: differ between runs).
    time_limit: float | None = None
    #: The first step's own bound [s] (``math.inf``: none), when every robot needs its
    #: first guide path (None: ``time_limit`` bounds it too). At 10,000 robots a step's
    #: ``time_limit`` cannot hold the first step's 10,000 searches, and the robots it
    #: leaves unguided become a backlog that later steps never clear.
    first_time_limit: float | None = None

    def __post_init__(self) -> None:
        for name in ("vertex_weight", "contraflow_weight", "turn_traffic_weight"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)!r}")
        if self.turn_contraflow_weight is not None and not self.turn_contraflow_weight >= 0:
            raise ValueError(
                f"turn_contraflow_weight must be >= 0 or None, got {self.turn_contraflow_weight!r}"
            )
        for name in ("turn_lane_paths", "floor_lane_paths", "learned_lane_paths"):
            lane_paths = getattr(self, name)
            if isinstance(lane_paths, bool) or not isinstance(lane_paths, int | np.integer):
                raise TypeError(f"{name} must be an int, got {lane_paths!r}")
            if not 0 <= lane_paths <= MAX_LANE_PATHS:
                raise ValueError(f"{name} must be in 0..{MAX_LANE_PATHS}, got {lane_paths!r}")
        if not self.heuristic_weight >= 1:
            raise ValueError(f"heuristic_weight must be >= 1, got {self.heuristic_weight!r}")
        if self.turn_cost is not None and not self.turn_cost >= 0:
            raise ValueError(f"turn_cost must be >= 0 or None, got {self.turn_cost!r}")
        if self.learn_period < 1:
            raise ValueError(f"learn_period must be >= 1, got {self.learn_period!r}")
        for name in ("search_batch", "first_search_batch"):
            size = getattr(self, name)
            if size is None and name == "first_search_batch":
                continue
            if isinstance(size, bool) or not isinstance(size, int | np.integer):
                raise TypeError(f"{name} must be an int, got {size!r}")
            if size < 1:
                raise ValueError(f"{name} must be >= 1, got {size!r}")
        if isinstance(self.workers, bool) or not isinstance(self.workers, int | np.integer):
            raise TypeError(f"workers must be an int, got {self.workers!r}")
        if not 1 <= self.workers <= MAX_WORKERS:
            raise ValueError(f"workers must be in 1..{MAX_WORKERS}, got {self.workers!r}")
        if isinstance(self.reroute, bool) or not isinstance(self.reroute, int | np.integer):
            raise TypeError(f"reroute must be an int, got {self.reroute!r}")
        if self.reroute < 0:
            raise ValueError(f"reroute must be >= 0, got {self.reroute!r}")
        if self.refresh < 0 or self.window < 1:
            raise ValueError(f"refresh must be >= 0 and window >= 1, got {self!r}")
        for name in ("max_searches", "later_max_searches", "later_max_expanded"):
            bound = getattr(self, name)
            if bound is None:
                continue
            if isinstance(bound, bool) or not isinstance(bound, int | np.integer):
                raise TypeError(f"{name} must be an int or None, got {bound!r}")
            if bound < 0:
                raise ValueError(f"{name} must be >= 0 or None, got {bound!r}")
        for name in ("time_limit", "first_time_limit"):
            value = getattr(self, name)
            if value is not None and not value >= 0:
                raise ValueError(f"{name} must be >= 0 or None, got {value!r}")
