"""Random delays as League of Robot Runners (LoRR) 2026 draws them, a tick at a time.

:class:`DelayConfig` is LoRR's ``delayConfig`` (validated as LoRR does, each fault one
line naming the field); :class:`DelayGenerator` draws its delays for a team, one
tick a call, and keeps every delay's interval for LoRR's ``delayIntervals`` output.
The model is LoRR's ``DelayGenerator`` (``src/DelayGenerator.cpp`` of its start kit,
read for these rules), restated in :class:`DelayGenerator`'s docstring. Every step is
an array operation over the team: a tick costs O(N), with no Python loop over robots.
Like :mod:`warehouse_phys.world.grid`, this module imports neither gymnasium, pymunk
nor pygame.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from warehouse_phys.execution.ticks import MAX_ROBOTS, check_whole

#: The delay models of LoRR 2026's ``delayConfig``.
EVENT_MODELS = ("bernoulli", "poisson")
DURATION_MODELS = ("uniform", "gaussian")
#: Longest delay [ticks]: LoRR holds durations in a C++ ``int``.
MAX_DELAY = 2**31 - 1
#: LoRR's seed is a C++ ``unsigned int``.
MAX_SEED = 2**32 - 1
#: LoRR's field names in ``delayConfig``, by this module's names.
JSON_NAMES = {
    "seed": "seed",
    "min_delay": "minDelay",
    "max_delay": "maxDelay",
    "event_model": "eventModel",
    "p_delay": "pDelay",
    "duration_model": "durationModel",
    "gauss_mean_ratio": "gaussMeanRatio",
    "gauss_std_ratio": "gaussStdRatio",
}

#: The integer fields' bounds, and the real fields' (checked as LoRR does).
_WHOLE_BOUNDS = (("seed", 0, MAX_SEED), ("min_delay", 1, MAX_DELAY), ("max_delay", 1, MAX_DELAY))
_REAL_BOUNDS = (("p_delay", 0, 1), ("gauss_mean_ratio", 0, 1), ("gauss_std_ratio", 0, math.inf))
#: Ticks with delays kept apart before they are joined into one block: the lists then
#: cost a tuple per 1,024 such ticks, not one (about 300 bytes) a tick.
_JOIN_EVERY = 1024


@dataclass(frozen=True)
class DelayConfig:
    """LoRR 2026's ``delayConfig``: how random delays are drawn, checked when built.

    LoRR's checks: ``1 <= min_delay <= max_delay``; ``p_delay`` in ``[0, 1]``; with
    ``"gaussian"`` durations, ``gauss_mean_ratio`` in ``[0, 1]`` and
    ``gauss_std_ratio >= 0``. Added here: integers are integers (never bools or floats),
    the seed fits LoRR's ``unsigned int`` and delays its ``int``, every real is finite,
    the models are the known names. The defaults of the two ratios are those of LoRR's
    ``DelayConfig`` struct (its JSON reader requires both fields, as :meth:`from_json`).

    Raises:
        TypeError, ValueError: one line naming the field (this class's name and LoRR's).
    """

    #: Seed of the delay draws, and the only source of their randomness.
    seed: int
    #: Shortest and longest delay [ticks].
    min_delay: int
    max_delay: int
    #: ``"bernoulli"`` or ``"poisson"``: how many robots a tick's delays hit.
    event_model: str
    #: Chance a tick that a robot is delayed (the Poisson rate is ``N * p_delay``).
    p_delay: float
    #: ``"uniform"`` or ``"gaussian"``: how long a delay lasts.
    duration_model: str
    #: The gaussian's mean, as a share of ``[min_delay, max_delay]`` from its start.
    gauss_mean_ratio: float = 0.5
    #: The gaussian's standard deviation, as a share of ``max_delay - min_delay``.
    gauss_std_ratio: float = 0.0

    def __post_init__(self) -> None:
        for name, low, high in _WHOLE_BOUNDS:
            value = check_whole(_field(name), getattr(self, name), low, high)
            object.__setattr__(self, name, value)  # a plain int, whatever integer was given
        if self.max_delay < self.min_delay:
            raise ValueError(
                f"{_field('max_delay')} must be at least min_delay ({self.min_delay}), "
                f"got {self.max_delay}"
            )
        for name, known in (("event_model", EVENT_MODELS), ("duration_model", DURATION_MODELS)):
            value = getattr(self, name)
            if not isinstance(value, str) or value not in known:
                raise ValueError(f"{_field(name)} must be one of {', '.join(known)}; got {value!r}")
        for name, low, high in _REAL_BOUNDS:
            value = _real(name, getattr(self, name))
            object.__setattr__(self, name, value)
            # LoRR checks the ratios only for gaussian durations, which alone use them.
            checked = name == "p_delay" or self.duration_model == "gaussian"
            if checked and not low <= value <= high:
                bound = f"in [{low}, {high}]" if high < math.inf else f"at least {low}"
                raise ValueError(f"{_field(name)} must be {bound}, got {value!r}")

    @classmethod
    def from_json(cls, data: object) -> DelayConfig:
        """The config of a ``delayConfig`` JSON object, as LoRR reads it: all eight fields
        required, others ignored.

        Raises:
            ValueError: a missing field, naming it; TypeError, ValueError: a bad value.
        """
        if not isinstance(data, dict):
            raise ValueError(f"delayConfig must be an object, got {data!r}")
        missing = [key for key in JSON_NAMES.values() if key not in data]
        if missing:
            raise ValueError(f"delayConfig is missing {', '.join(map(repr, missing))}")
        return cls(**{name: data[key] for name, key in JSON_NAMES.items()})

    def to_json(self) -> dict[str, Any]:
        """The ``delayConfig`` object as LoRR writes it."""
        return {key: getattr(self, name) for name, key in JSON_NAMES.items()}


class DelayIntervals(NamedTuple):
    """Every delay drawn so far, ordered by start tick, then robot; ``int64`` arrays."""

    #: The robot delayed.
    robot: np.ndarray
    #: The first tick it is delayed.
    start: np.ndarray
    #: The first tick after the delay: delayed for ticks ``start .. end - 1``.
    end: np.ndarray


class DelayGenerator:
    """A team's random delays, drawn a tick at a time as LoRR 2026 draws them.

    ## The rules (LoRR's ``DelayGenerator::nextTick``, once a tick)
    Each robot holds ``remaining``, the ticks of delay it has left (0 at first).
    :meth:`next_tick` draws tick ``t`` (0, 1, 2, ...):

    1. Every ``remaining`` above 0 drops by 1.
    2. The *available* robots are those with ``remaining == 0``: a robot in a delay
       is never hit again until that delay is over; one whose delay ended at this
       tick is available at once (so a robot can have ``[a, t]`` then ``[t, b]``).
    3. How many available robots are hit, ``K``:

       - ``"bernoulli"``: each available robot independently with chance ``p_delay``;
       - ``"poisson"``: ``K = min(Poisson(N * p_delay), available)``, with ``N`` the
         whole team (delayed robots included, as LoRR's ``teamSize * pDelay``), the
         ``K`` robots drawn uniformly without replacement from the available ones.
    4. Each robot hit draws a duration ``d`` in ``[min_delay, max_delay]``:

       - ``min_delay == max_delay``: ``d = min_delay``, no draw;
       - ``"uniform"``: uniform over the integers of the range;
       - ``"gaussian"``: with ``span = max_delay - min_delay``, a normal draw of mean
         ``min_delay + span * gauss_mean_ratio`` and standard deviation
         ``span * gauss_std_ratio`` (the mean itself when that is 0), rounded half away
         from zero (C's ``lround``) and clipped to the range.
    5. Its ``remaining`` becomes ``d`` and its interval ``[t, t + d]`` is kept.

    The robots delayed at tick ``t`` are those with ``remaining > 0`` after these steps:
    a delay drawn at tick ``t`` holds its robot at ticks ``t .. t + d - 1`` (``d``
    ticks), and the robot is free again at tick ``t + d``. LoRR's ``delayIntervals``
    writes that delay ``[t, t + d]``: the end is the first free tick.

    ## A delayed robot (LoRR's simulator, which the executor follows)
    A robot delayed at tick ``t`` does nothing at tick ``t``, whatever its command: a
    move it has begun is paused with its tick counter held (not reset) and goes on
    when the delay is over; the tick counts as a wait in its path. LoRR draws the
    delays of tick ``t`` before it moves the robots at tick ``t``: call
    :meth:`next_tick` once a tick, before the moves, and hold the robots it returns.

    ## Randomness
    All of it comes from one :class:`numpy.random.Generator` seeded with the config's
    ``seed`` and nothing else: the same config and team size give the same delays in
    any process on any machine, for one numpy version. The draws are not LoRR's
    ``std::mt19937`` stream (whose distributions differ between C++ libraries anyway),
    only its model. A tick draws ``K`` from its law, then the ``K`` robots as a
    uniform subset of the available ones: for ``"bernoulli"`` that is exactly the law
    of one coin a robot (every subset of size ``K`` is as likely), with ``O(K)`` draws.

    ## Memory
    ``remaining`` is one integer a robot; the intervals take three integers a delay
    (24 bytes), never a row a tick: a tick without delays stores nothing.
    """

    def __init__(self, config: DelayConfig, n_robots: int) -> None:
        if not isinstance(config, DelayConfig):
            raise TypeError(f"config must be a DelayConfig, got {type(config).__name__}")
        self.config = config
        self.n_robots = check_whole("n_robots", n_robots, 0, MAX_ROBOTS)
        self._rng = np.random.default_rng(config.seed)
        self._remaining = np.zeros(self.n_robots, dtype=np.int64)
        self._tick = 0
        # (robots, starts, durations) of the delays drawn: an entry a tick with delays,
        # each run of _JOIN_EVERY entries joined into one block.
        self._blocks: list[tuple[np.ndarray, ...]] = []
        self._recent: list[tuple[np.ndarray, ...]] = []

    @property
    def tick(self) -> int:
        """How many ticks have been drawn: the next tick's number."""
        return self._tick

    @property
    def remaining(self) -> np.ndarray:
        """Ticks of delay each robot has left, this tick included (read-only view)."""
        view = self._remaining.view()
        view.flags.writeable = False
        return view

    def next_tick(self) -> np.ndarray:
        """Draw tick :attr:`tick` by the rules of the class docstring; returns which robots
        are delayed at it, a fresh ``(n_robots,)`` bool array."""
        remaining = self._remaining
        np.subtract(remaining, 1, out=remaining, where=remaining > 0)
        available = np.flatnonzero(remaining == 0)
        hit = self._draw_hit(available)
        if len(hit):
            durations = self._draw_durations(len(hit))
            remaining[hit] = durations
            self._recent.append((hit, np.full(len(hit), self._tick, np.int64), durations))
            if len(self._recent) >= _JOIN_EVERY:
                self._blocks.append(_joined(self._recent))
                self._recent = []
        self._tick += 1
        return remaining > 0

    def intervals(self) -> DelayIntervals:
        """Every delay drawn so far (fresh arrays)."""
        robot, start, duration = _joined([*self._blocks, *self._recent])
        return DelayIntervals(robot, start, start + duration)

    def intervals_json(self) -> list[list[list[int]]]:
        """LoRR's ``delayIntervals``: one list a robot of its ``[start, end]`` pairs, in
        order of start."""
        robot, start, end = self.intervals()
        order = np.argsort(robot, kind="stable")  # stable: each robot's starts stay sorted
        pairs = np.stack([start[order], end[order]], axis=1).tolist()
        bounds = np.searchsorted(robot[order], np.arange(self.n_robots + 1)).tolist()
        return [pairs[bounds[i] : bounds[i + 1]] for i in range(self.n_robots)]

    def _draw_hit(self, available: np.ndarray) -> np.ndarray:
        """The available robots a tick's delays hit, in increasing order."""
        config, rng = self.config, self._rng
        if config.event_model == "bernoulli":
            count = int(rng.binomial(len(available), config.p_delay))
        else:
            count = min(int(rng.poisson(self.n_robots * config.p_delay)), len(available))
        if count == 0 or count == len(available):
            return available[:count]
        return np.sort(rng.choice(available, size=count, replace=False, shuffle=False))

    def _draw_durations(self, count: int) -> np.ndarray:
        """``count`` delay durations [ticks], by the config's duration model."""
        config, rng = self.config, self._rng
        low, high = config.min_delay, config.max_delay
        if low == high:
            return np.full(count, low, dtype=np.int64)
        if config.duration_model == "uniform":
            return rng.integers(low, high, size=count, endpoint=True, dtype=np.int64)
        span = high - low
        mean, deviation = low + span * config.gauss_mean_ratio, span * config.gauss_std_ratio
        drawn = np.full(count, mean) if deviation <= 0 else rng.normal(mean, deviation, count)
        rounded = np.copysign(np.floor(np.abs(drawn) + 0.5), drawn)  # C's lround
        return np.clip(rounded, low, high).astype(np.int64)


def _joined(parts: list[tuple[np.ndarray, ...]]) -> tuple[np.ndarray, ...]:
    """The columns of ``parts`` joined into fresh arrays (empty ``int64`` ones for none)."""
    if not parts:
        return tuple(np.zeros(0, dtype=np.int64) for _ in range(3))
    return tuple(np.concatenate(column) for column in zip(*parts, strict=True))


def _field(name: str) -> str:
    """A field's name for an error: this module's and LoRR's."""
    return f"{name} (delayConfig.{JSON_NAMES[name]})"


def _real(name: str, value: object) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{_field(name)} must be a number, got {value!r} ({type(value).__name__})")
    try:
        real = float(value)
    except OverflowError:  # an integer beyond any float
        raise ValueError(
            f"{_field(name)} must be finite, got an integer of {int(value).bit_length():,} bits"
        ) from None
    if not math.isfinite(real):
        raise ValueError(f"{_field(name)} must be finite, got {value!r}")
    return real
