"""The sweep on Ray Tune: Ray's set-up and shut-down, the experiment, the trainable.

:func:`ray_session` connects to a Ray cluster (``--address``) or starts a local one,
and shuts down a Ray it started however the block ends (SIGINT, SIGTERM). Nothing waits
for resources that cannot come: an address where no cluster answers fails within
:data:`CONNECT_TIMEOUT` (:func:`check_address`), and a trial needing more CPUs than
there are is refused (:func:`check_cpus_per_trial`). :func:`run_on_tune` runs the
trials as one Tune experiment, one line for each finished trial; each trains in a
worker (:func:`run_trial`) through the same code as ``python -m warehouse_phys.train``.
"""

from __future__ import annotations

import logging
import os
import signal
import socket
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from warehouse_phys.apps.cli import UsageError
from warehouse_phys.apps.interrupts import Terminated
from warehouse_phys.apps.runs import Floor
from warehouse_phys.apps.sweep.resume import TrialFolder
from warehouse_phys.apps.sweep.trials import _measures
from warehouse_phys.rl.qlearning import QLearningConfig

#: How long ``--address host:port`` may take to accept a connection [s].
CONNECT_TIMEOUT = 5.0


class RayUnavailableError(Exception):
    """No Ray cluster could be reached or started; the message says why, in one line."""


class AddressRefusedError(RayUnavailableError):
    """An ``--address`` refused: not an address, or no Ray cluster answers there (``auto``:
    none running). A refused argument, as the command lines' exit status 2 says."""


#: Set once SIGTERM arrives: Tune may re-raise the interrupt as a plain KeyboardInterrupt.
_terminated = threading.Event()


def _terminate(signum: int, frame: object) -> None:
    _terminated.set()
    raise Terminated  # so that the Ray processes started are shut down


def check_address(address: str) -> None:
    """Fail at once where nothing listens at ``address`` (``host:port`` or ``ray://host:port``).

    Ray itself retries an address for minutes. ``auto`` and ``local`` are left to Ray.

    Raises:
        AddressRefusedError: if ``address`` is not an address, or no connection opens
            within :data:`CONNECT_TIMEOUT`.
    """
    if address in ("auto", "local"):
        return
    host, colon, port = address.removeprefix("ray://").rpartition(":")
    if not colon or not port.isdigit() or not host:
        raise AddressRefusedError(
            f"--address {address}: expected host:port, ray://host:port, auto or local"
        )
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT):
            pass
    except (OSError, OverflowError) as error:
        reason = getattr(error, "strerror", None) or str(error) or type(error).__name__
        raise AddressRefusedError(
            f"--address {address}: no Ray cluster answers: {reason}"
        ) from None


def check_cpus_per_trial(cpus_per_trial: int, available: float, where: str) -> None:
    """Refuse a trial that needs more CPUs than ``where`` has: Ray would wait for ever.

    Raises:
        UsageError: naming the CPUs available.
    """
    if cpus_per_trial > available:
        raise UsageError(
            f"--cpus-per-trial {cpus_per_trial}: {where} has {available:g} CPUs, so no trial "
            "could ever start"
        )


@contextmanager
def ray_session(
    address: str | None, cpus_per_trial: int, *, prestart_workers: bool = True
) -> Iterator[None]:
    """Ray for the sweep: connected to ``address``, or a local Ray started here.

    A Ray this call started is shut down when the block ends, however it ends:
    SIGINT and (while the block lasts) SIGTERM interrupt it as
    ``KeyboardInterrupt``. A Ray already running in the process is used as it is.
    ``prestart_workers=False``: a local Ray started here starts no idle worker ahead of
    the first task (by default it starts one a CPU); a cluster keeps its own settings.

    Raises:
        AddressRefusedError: if no cluster answers at ``address``.
        RayUnavailableError: if a local Ray (``address`` ``None`` or ``"local"``) cannot
            start.
        UsageError: if the cluster has fewer CPUs than ``cpus_per_trial``.
    """
    import ray

    if ray.is_initialized():
        yield
        return
    if address is not None:
        check_address(address)
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.getsignal(signal.SIGTERM) if main_thread else None
    options: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False,
                               "logging_level": logging.ERROR}  # fmt: skip
    try:
        if main_thread:
            signal.signal(signal.SIGTERM, _terminate)
        try:
            if address is None:
                if not prestart_workers:
                    options["_system_config"] = {"prestart_worker_first_driver": False}
                ray.init(num_cpus=os.cpu_count() or 1, **options)
            else:
                ray.init(address=address, **options)
        except (ConnectionError, RuntimeError, ValueError) as error:
            lines = str(error).strip().splitlines() or [type(error).__name__]
            if address is None:
                raise RayUnavailableError(f"cannot start a local Ray: {lines[0]}") from None
            if address == "local":  # a local Ray asked for by name: no address refused
                raise RayUnavailableError(f"--address local: {lines[0]}") from None
            raise AddressRefusedError(f"--address {address}: {lines[0]}") from None
        if main_thread:
            signal.signal(signal.SIGTERM, _terminate)  # ray.init installs its own
        if address is not None:
            cpus = ray.cluster_resources().get("CPU", 0)
            check_cpus_per_trial(cpus_per_trial, cpus, f"the cluster at {address}")
        yield
    finally:
        ray.shutdown()
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def run_on_tune(
    jobs: Sequence[dict[str, Any]],
    sweep_dir: Path,
    *,
    address: str | None,
    cpus_per_trial: int,
    max_concurrent: int | None,
    quiet: bool,
) -> dict[str, dict[str, Any] | BaseException]:
    """Run ``jobs`` as one Ray Tune experiment; each trial's measures, or its error, by name."""
    # Tune's own console output (a configuration box, TensorBoard hints) gives way to
    # one line per finished trial (the Progress callback below).
    os.environ.setdefault("RAY_AIR_NEW_OUTPUT", "0")
    os.environ.setdefault("TUNE_DISABLE_AUTO_CALLBACK_LOGGERS", "1")
    # Ctrl-C interrupts at once (and ray_session shuts Ray down) rather than waiting
    # for Tune to stop the trials gracefully.
    os.environ.setdefault("TUNE_DISABLE_SIGINT_HANDLER", "1")
    from ray import tune

    total = len(jobs)

    class Progress(tune.Callback):
        """One line per finished trial: what matters of Tune's reporting."""

        def __init__(self) -> None:
            self.done = 0

        def on_trial_complete(self, iteration: int, trials: list, trial: Any, **info: Any) -> None:
            self._report(trial, "done")

        def on_trial_error(self, iteration: int, trials: list, trial: Any, **info: Any) -> None:
            self._report(trial, "FAILED")

        def _report(self, trial: Any, status: str) -> None:
            self.done += 1
            if not quiet:
                print(f"[{self.done}/{total}] {trial.config['job']['name']}: {status}", flush=True)

    # A local Ray prestarts no idle workers (one a CPU by default): Tune runs the trials
    # in workers of their own, set up for the sweep's job, so those would never be used,
    # only paid for (half a second of CPU each, just as the trials' workers start).
    with ray_session(address, cpus_per_trial, prestart_workers=False):
        trainable = tune.with_resources(run_trial_job, {"cpu": cpus_per_trial})
        tuner = tune.Tuner(
            trainable,
            param_space={"job": tune.grid_search(list(jobs))},
            # One worker runs trial after trial (the trainable seeds each from its own
            # job), rather than a fresh process importing the package for every trial:
            # a quarter off a small sweep's wall time.
            tune_config=tune.TuneConfig(max_concurrent_trials=max_concurrent, reuse_actors=True),
            run_config=tune.RunConfig(
                name="tune",
                storage_path=str((sweep_dir / "tune").resolve()),
                verbose=0,
                callbacks=[Progress()],
                failure_config=tune.FailureConfig(max_failures=0),
            ),
        )
        logging.getLogger("ray").setLevel(logging.CRITICAL)
        grid = tuner.fit()
    outcomes: dict[str, dict[str, Any] | BaseException] = {}
    for result in grid:
        name = result.config["job"]["name"]
        outcomes[name] = result.error if result.error is not None else dict(result.metrics)
    return outcomes


def run_trial_job(config: dict[str, Any]) -> dict[str, Any]:
    """Tune's trainable: the trial in ``config["job"]`` (see :func:`run_trial`)."""
    return run_trial(config["job"])


def run_trial(job: dict[str, Any]) -> dict[str, Any]:
    """Train one trial in the current process and write its run folder: Tune's trainable.

    Imports what it needs here, in the worker; the environments are made with
    ``warehouse_phys:`` ids, which register the package in any process.
    Returns the trial's row of the results table.
    """
    from warehouse_phys.apps.runs import train_run

    floor_fields = dict(job["floor"])
    if floor_fields.get("layout") is not None:
        floor_fields["layout"] = tuple(floor_fields["layout"])
    floor = Floor(**floor_fields)
    config = QLearningConfig(**job["config"])
    folder = TrialFolder(job["folder"], job["lock"], job.get("run"))
    with folder:
        outcome = train_run(folder, floor, job["env"], config, gif=job["gif"])
    return _measures(outcome.summary)
