"""The start kit's loop restated: the entry's run by the kit's rules has no square collision
whatever the delays, its output file walks back to its own counts, runs repeat bit for bit,
and replayed delays give back every interval of the kit run they came from."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.lorr.tiny_kit_instance import STATIONS, station_instance, tiny_instance
from warehouse_phys.execution.delay_replay import DelayReplay
from warehouse_phys.lorr.output_2026 import read_output, walk, write_output
from warehouse_phys.lorr.startkit.system import KitSystem
from warehouse_phys.lorr.station_cap import STATION_CAP
from warehouse_phys.planners.named import PLANNERS

GOLDEN = Path(__file__).with_name("data") / "kit_tiny_output.json"


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([0.0, 0.05, 0.2]), st.sampled_from([1, 3]),
       st.sampled_from(PLANNERS))  # fmt: skip
def test_no_square_ever_collides_and_the_output_walks_back(tmp_path_factory, seed, p, counter,
                                                          planner):  # fmt: skip
    base = tiny_instance()
    instance = dataclasses.replace(
        base, agent_counter=counter, delay=dataclasses.replace(base.delay, seed=seed, p_delay=p)
    )
    system = KitSystem(instance, planner=planner, seed=seed)
    system.run(150)
    assert system.collisions == []
    assert system.tasks.schedule_errors == []
    path = write_output(tmp_path_factory.mktemp("out") / "out.json", system.output())
    read = read_output(path)
    assert read.data["numTaskFinished"] == system.tasks.tasks_done
    steps = walk(read, instance.grid)
    assert steps.collisions == []
    assert (steps.cells[-1] == system.executor.executor.left).all()
    assert (steps.headings[-1] == system.executor.executor.headings).all()


def test_a_run_repeats_bit_for_bit_and_a_reset_starts_it_again():
    system = KitSystem(tiny_instance())
    first = _run(system, 120)
    system.reset()
    assert _run(system, 120) == first
    assert _run(KitSystem(tiny_instance()), 120) == first


def _run(system, ticks):
    """The run's output file, but its planner times (the rounds' CPU time)."""
    system.run(ticks)
    data = system.output().to_json()
    assert len(data.pop("plannerTimes")) == 12
    return json.dumps(data)


def test_replayed_delays_give_back_every_interval_of_the_kit_run():
    kit = read_output(GOLDEN)
    recorded = kit.actual.shape[1]
    replay = DelayReplay(kit.data["delayIntervals"], recorded)
    system = KitSystem(tiny_instance(), delays=replay)
    system.run(recorded)
    assert system.output().delay_intervals == kit.data["delayIntervals"]
    assert sum(map(len, kit.data["delayIntervals"])) > 10
    with pytest.raises(ValueError, match="cover"):
        system.step()


def test_a_2023_instance_or_an_unknown_part_is_refused():
    instance = dataclasses.replace(tiny_instance(), version=None, assignment="roundrobin")
    with pytest.raises(ValueError, match="2023"):
        KitSystem(instance)
    with pytest.raises(ValueError, match="unknown scheduler"):
        KitSystem(tiny_instance(), scheduler="random")
    with pytest.raises(TypeError, match="delays"):
        KitSystem(tiny_instance(), delays={"pDelay": 1})
    assert np.isfinite(KitSystem(tiny_instance()).agent_size)


MAZE = (
    Path(__file__).resolve().parents[3]
    / "shared"
    / "lorr"
    / "2026-examples-maze"
    / "maze-example_40.json"
)


@pytest.mark.skipif(not MAZE.is_file(), reason=f"no LoRR 2026 instances at {MAZE.parent} "
                    "(data beside the checkout, not in the repository)")  # fmt: skip
def test_the_maze_example_never_locks_up():
    """Turning PIBT that may not rotate locks this maze's robots in its narrow loops (with
    the makespan pairing, on the instance's delays: 51, 27, 5 and 0 tasks in the four
    500-tick spans of 2,000 ticks); the detours of stuck robots keep them moving."""
    from warehouse_phys.lorr.instances import read_instance

    system = KitSystem(read_instance(MAZE), scheduler="makespan", check_squares=False)
    done = []
    for _ in range(4):
        system.run(500)
        done.append(system.tasks.tasks_done)
    assert min(np.diff([0, *done])) >= 30, done


#: Digests of the tiny instance's 200-tick run by the kit's rules (its output file, the
#: planner's times aside), with the entry's guidance of ``ENTRY_GUIDANCE`` and its
#: scheduler pairing again: a speed-up that changes a single action changes them (PIBT's
#: look-ups for guided robots only were checked the same way, on random-example_400,
#: maze-example_40 and 2,500 robots). Without pairing again and with the guidance's
#: earlier weight (``vertex_weight`` 0.1), ``guided`` and ``pibt`` give the digests they
#: had before either (41bb28c5... and 8d77f587...).
ENTRY_GOLDEN = {
    "guided-ops-repair": "13c829c0592dded48816efb63db3eebc1b668f1c37e6192659abf1384df1794c",
    "guided": "1be53671c69f9c45d301bfb848676b4096bfad2ee44d05a3c50431c8290c6afc",
    "pibt": "6f797906e84bfeddd395a0ca90cd8e4cc77ea0cfce14b47c8a811a76f582b569",
}


@pytest.mark.parametrize("planner", sorted(ENTRY_GOLDEN))
def test_the_entrys_runs_are_the_golden_ones(planner):
    import hashlib

    system = KitSystem(tiny_instance(), planner=planner)
    system.run(200)
    output = system.output().to_json()
    output.pop("plannerTimes")
    digest = hashlib.sha256(json.dumps(output, sort_keys=True).encode()).hexdigest()
    assert digest == ENTRY_GOLDEN[planner]


def test_the_capped_entry_never_sends_a_station_more_than_the_cap():
    """Each round of the kit's loop with ``assignment-capped``: the robots on their way to
    a station as the entry counts them (a task not opened by the end of their staged
    actions, a task held for them) never exceed the cap where they did not before;
    without the cap they do."""
    instance = station_instance()
    stop_of = instance.task_stops[instance.task_offsets[:-1]]

    def loads(going):
        firsts = stop_of[going % instance.num_tasks]
        return np.array([(firsts == station).sum() for station in STATIONS])

    most = {}
    for scheduler in ("assignment", "assignment-capped"):
        system = KitSystem(instance, scheduler=scheduler)
        entry, rounds = system.scheduler, []

        def counted(current, cells, tasks, finishing=None, unopened=None, entry=entry,
                    rounds=rounds):  # fmt: skip
            before = loads(np.concatenate([current[unopened], entry.held[entry.held >= 0]]))
            proposal = type(entry).schedule(entry, current, cells, tasks, finishing, unopened)
            kept_or_new = (proposal >= 0) & ((proposal != current) | unopened)
            after = loads(np.concatenate([proposal[kept_or_new], entry.held[entry.held >= 0]]))
            rounds.append((before, after))
            return proposal

        entry.schedule = counted
        system.run(300)
        assert system.tasks.tasks_done > 0
        most[scheduler] = max(after.max() for _, after in rounds)
        if scheduler == "assignment-capped":
            for before, after in rounds:
                assert (after <= np.maximum(before, STATION_CAP)).all(), (before, after)
    assert most["assignment-capped"] == STATION_CAP < most["assignment"]
