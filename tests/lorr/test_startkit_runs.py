"""The entry in the start kit itself (skipped without the kit's source or build): the kit's
own collision verdicts are the swept-square rule's, the kit's run of the entry is the
package's own simulation of it, the adapters on the kit's MAPF types, and the command."""

import json

import numpy as np
import pytest

from tests.lorr.kit import KIT, built_kit, corner, kit_step, mapf_module, scripted_run
from tests.lorr.tiny_kit_instance import station_instance, tiny_instance
from warehouse_phys.apps import startkit
from warehouse_phys.execution.delay_replay import DelayReplay
from warehouse_phys.execution.delays import DelayConfig
from warehouse_phys.execution.swept_squares import boxes_collide
from warehouse_phys.lorr.instances import LorrInstance, write_instance
from warehouse_phys.lorr.output_2026 import TIMEOUT, decode_path, read_output
from warehouse_phys.lorr.startkit import adapters, settings
from warehouse_phys.lorr.startkit.runs import run_kit
from warehouse_phys.lorr.startkit.system import KitSystem
from warehouse_phys.world.grid import WarehouseGrid

FORWARD, CLOCKWISE, WAIT = 0, 1, 3
#: The entry's setting for the runs compared with the package's simulation of them: the
#: planner's round unbounded in time, so that a busy machine (the suite's other worker)
#: makes the kit's plans late, which the tests see, never different, which they cannot
#: tell from a wrong entry (the bound cut the guide searches of a round short on a loaded
#: machine, and the paths parted at tick 3).
UNBOUNDED = {"WAREHOUSE_PHYS_ROUND_SHARE": "none"}


def pairs_instance(ticks_per_move, cols=540):
    """Leader and follower pairs far to the east (where a float's step is 3e-5 to 6e-5): in
    row 1 each leader turns south and drives on while its follower enters its cell round
    the corner; in row 4 each leader drives straight on, its follower behind it."""
    grid = WarehouseGrid.from_layout(["." * cols] * 7)
    firsts = list(range(502, 530, 4))
    starts = [cell for c in firsts for cell in (1 * cols + c, 1 * cols + c - 1)]
    starts += [cell for c in firsts for cell in (4 * cols + c, 4 * cols + c - 1)]
    return LorrInstance(name="pairs", grid=grid, starts=starts, task_offsets=[0, 1],
                        task_stops=[0], num_tasks_reveal=0.01, assignment="scheduler",
                        version="2026 LoRR", agent_counter=ticks_per_move, agent_size=1.0,
                        delay=DelayConfig(seed=0, min_delay=1, max_delay=1,
                                          event_model="bernoulli", p_delay=0.0,
                                          duration_model="uniform"))  # fmt: skip


def scripts_of(n_pairs, ticks_per_move):
    """Leaders' and followers' actions: each follower starts a different number of ticks
    after its leader."""
    scripts = []
    for corner_pair in (True, False):
        for k in range(n_pairs):
            leader = [CLOCKWISE, FORWARD, FORWARD] if corner_pair else [FORWARD] * 3
            follower = [WAIT] * (k % (ticks_per_move + 2)) + [FORWARD] * 3
            scripts += [leader, follower]
    return scripts


def predicted(instance, scripts, ticks):
    """Each robot's actual action at each tick and the motions refused, by the swept-square
    rule: a leader is never kept back; a follower is, when its square would collide with
    its leader's in the tick."""
    cols, t_move = instance.grid.cols, instance.agent_counter
    n = instance.team_size
    state = [{"cell": int(c), "heading": 0, "count": 0, "doing": -1} for c in instance.starts]
    queues = [list(s) for s in scripts]
    actual = np.full((n, ticks), WAIT, dtype=np.int8)
    refused = set()
    for t in range(ticks):
        for leader in range(0, n, 2):
            moves = {}
            for robot in (leader, leader + 1):
                wanted = queues[robot][0] if queues[robot] else WAIT
                moves[robot] = (wanted, kit_step(state[robot], wanted, t_move, cols))
            (l_act, l_new), (f_act, f_new) = moves[leader], moves[leader + 1]
            if f_act != WAIT and boxes_collide(
                corner(state[leader + 1], t_move, cols), corner(f_new, t_move, cols),
                corner(state[leader], t_move, cols), corner(l_new, t_move, cols), 1.0,
            )[0]:  # fmt: skip
                refused.add((leader + 1, t))
                f_act, f_new = WAIT, kit_step(state[leader + 1], WAIT, t_move, cols)
            for robot, act, new in ((leader, l_act, l_new), (leader + 1, f_act, f_new)):
                actual[robot, t] = act
                moved = (new["cell"], new["heading"]) != (state[robot]["cell"],
                                                          state[robot]["heading"])  # fmt: skip
                if queues[robot] and (moved or (queues[robot][0] == WAIT and act == WAIT)):
                    queues[robot].pop(0)
                state[robot] = new
    return actual, refused


@pytest.mark.parametrize("ticks_per_move", [3, 5])
def test_the_kits_verdicts_on_corner_and_straight_follows_are_the_swept_square_rules(
    tmp_path, ticks_per_move
):
    build = built_kit()
    instance = pairs_instance(ticks_per_move)
    path = write_instance(instance, tmp_path / "pairs.json")
    scripts = scripts_of(7, ticks_per_move)
    output, refused = scripted_run(build, path, scripts, 12 * ticks_per_move, tmp_path)
    actual = np.stack([decode_path(p, 100)[0] for p in output["actualPaths"]])
    expected, expected_refused = predicted(instance, scripts, actual.shape[1])
    assert refused == expected_refused
    assert len(refused) > 20  # followers were kept back, round corners and behind leaders
    assert actual.tolist() == expected.tolist()


def test_a_kit_run_of_the_entry_is_the_packages_simulation_of_it(tmp_path):
    build = built_kit()
    instance = tiny_instance()
    path = write_instance(instance, tmp_path / "tiny.json")
    result = run_kit(build, path, tmp_path / "ours.json", 80, settings=UNBOUNDED)
    assert result.returncode == 0, result.note
    assert (result.refused_motions, result.planner_errors) == (0, 0)
    # A finished task proposed again only when the executor could not wait for the scheduler
    # (a loaded machine): the kit's bridge then writes the answer over the freed robot.
    assert result.schedule_errors == 0 or result.scheduler_late > 0
    kit = read_output(tmp_path / "ours.json")
    recorded = kit.actual.shape[1]
    system = KitSystem(instance, delays=DelayReplay(kit.data["delayIntervals"], recorded))
    system.run(recorded)
    ours = np.stack([decode_path(p, 100)[0] for p in system.output().actual_paths])
    late = np.flatnonzero((kit.planned == TIMEOUT).all(axis=0))  # ticks the entry was late
    same = recorded if not len(late) else int(late[0])
    assert (ours[:, :same] == kit.actual[:, :same]).all()
    if not len(late) and recorded == 80:
        assert system.tasks.tasks_done == kit.data["numTaskFinished"]
        assert system.output().events == kit.data["events"]


@pytest.fixture(scope="module")
def capped_kit_run(tmp_path_factory):
    """``python -m warehouse_phys.startkit run --only ours`` of the station instance with
    ``--scheduler assignment-capped``, 120 ticks, the entry's round unbounded
    (:data:`UNBOUNDED`): the kit's own run of the entry (its
    ``lifelong``, through :func:`run_kit` with the entry's settings), once for the two tests
    that read it; the instance, the command's argument list less ``--only``, its output
    folder and its exit status."""
    built_kit()
    folder = tmp_path_factory.mktemp("capped")
    instance = station_instance()
    path = write_instance(instance, folder / "instance" / "stations.json")
    out = folder / "out"
    argv = ["run", str(path), "--kit", str(KIT), "--ticks", "120", "--out", str(out),
            "--scheduler", "assignment-capped"]  # fmt: skip
    with pytest.MonkeyPatch.context() as patch:
        for name, value in UNBOUNDED.items():
            patch.setenv(name, value)
        status = startkit.main([*argv, "--only", "ours"])
    return instance, argv, out, status


def test_the_kit_runs_the_entry_with_the_capped_scheduler_as_the_package_does(capped_kit_run):
    instance, _, out, status = capped_kit_run
    assert status == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["scheduler"] == "assignment-capped"
    result = next(run for run in summary["runs"] if run["name"] == "ours")
    assert result["returncode"] == 0, result["note"]
    assert (result["refused_motions"], result["planner_errors"]) == (0, 0)
    assert result["schedule_errors"] == 0 or result["scheduler_late"] > 0
    kit = read_output(out / "ours.json")
    assert kit.data["numTaskFinished"] > 0
    recorded = kit.actual.shape[1]
    replay = DelayReplay(kit.data["delayIntervals"], recorded)
    system = KitSystem(instance, scheduler="assignment-capped", delays=replay)
    system.run(recorded)
    ours = np.stack([decode_path(p, 100)[0] for p in system.output().actual_paths])
    late = np.flatnonzero((kit.planned == TIMEOUT).all(axis=0))
    same = recorded if not len(late) else int(late[0])
    assert (ours[:, :same] == kit.actual[:, :same]).all()
    if not len(late) and recorded == 120:
        assert system.output().events == kit.data["events"]
    # The setting reached the kit's entry: without the cap the robots go otherwise.
    uncapped = KitSystem(instance, scheduler="assignment", delays=replay)
    uncapped.run(recorded)
    other = np.stack([decode_path(p, 100)[0] for p in uncapped.output().actual_paths])
    assert (other[:, :same] != kit.actual[:, :same]).any()


def kit_environment(mapf, instance):
    """The kit's ``SharedEnvironment`` of ``instance`` at its start, built from the kit's own
    types (``mapf``), with its first 12 tasks in the pool."""
    env = mapf.SharedEnvironment()
    grid, n = instance.grid, instance.team_size
    env.num_of_agents, env.rows, env.cols = n, grid.rows, grid.cols
    env.map = mapf.VectorInt((~grid.free_mask).astype(int).ravel().tolist())
    env.min_planner_communication_time, env.action_time, env.max_counter = 1000, 100, 3
    states = mapf.VectorState([mapf.State(int(s), 0, 0) for s in instance.starts])
    env.curr_states, env.system_states = states, states
    env.staged_actions = mapf.VectorVectorAction([mapf.VectorAction() for _ in range(n)])
    env.curr_task_schedule = mapf.VectorInt([-1] * n)
    pool = mapf.TaskPool()
    for t in range(12):
        task = mapf.Task()
        task.task_id, task.idx_next_loc, task.agent_assigned = t, 0, -1
        task.locations = mapf.VectorInt(instance.task(t).tolist())
        pool[t] = task
    env.task_pool = pool
    return env


def test_the_adapters_speak_the_kits_own_types(tmp_path):
    mapf = mapf_module(built_kit(), tmp_path)
    instance = tiny_instance()
    n = instance.team_size
    env = kit_environment(mapf, instance)
    parts = [adapters.SchedulerAdapter(), adapters.PlannerAdapter(), adapters.ExecutorAdapter()]
    for part in parts:
        part.env = env
        part.initialize(30_000)
    scheduler, planner, executor = parts
    proposal = scheduler.plan(1000)
    system = KitSystem(instance)  # the same entry, on the same start
    assert proposal == system._proposal.tolist()
    env.curr_task_schedule = mapf.VectorInt(proposal)
    plan = mapf.Plan()
    plan.actions = mapf.VectorVectorAction(
        [mapf.VectorAction([mapf.Action(a) for a in row]) for row in planner.plan(1000)]
    )  # fmt: skip
    assert [[int(a) for a in row] for row in plan.actions] == system._plan.tolist()
    staged = mapf.VectorVectorAction([mapf.VectorAction() for _ in range(n)])
    predicted_states = executor.process_new_plan(100, plan, staged)
    system.step()  # the same plan staged by the simulation's executor
    queue = system.executor.executor.queue_actions()
    assert [[int(a) for a in row] for row in staged] == [[a for a in row if a >= 0]
                                                          for row in queue.tolist()]  # fmt: skip
    cells, headings = system.executor.predicted()
    assert [(s.location, s.orientation) for s in predicted_states] == list(
        zip(cells.tolist(), headings.tolist(), strict=True)
    )
    commands = executor.next_command(100)
    assert set(commands) <= {0, 1}
    assert 0 in commands
    assert json.dumps(settings.SETTINGS)  # the settings the components read, documented


def test_the_round_share_bounds_the_planners_round_unless_none(tmp_path, monkeypatch):
    mapf = mapf_module(built_kit(), tmp_path)  # one module for the three settings
    env = kit_environment(mapf, tiny_instance())
    for share, bounded in ((None, True), ("0.25", True), ("none", False)):
        if share is not None:
            monkeypatch.setenv("WAREHOUSE_PHYS_ROUND_SHARE", share)
        planner = adapters.PlannerAdapter()
        planner.env = env
        planner.initialize(30_000)
        asked = []

        def spy(*args, seconds, plan=planner.core.plan, asked=asked):
            asked.append(seconds)
            return plan(*args)

        planner.core.plan = spy
        planner.plan(1000)  # [ms]
        assert (asked[0] is not None) == bounded, share
        # At most the share of the round's 1 s (less where this process's scheduler, of an
        # earlier test, began the round before).
        assert not bounded or 0 <= asked[0] <= float(share or settings.ROUND_SHARE)


def test_the_command_runs_the_three_and_writes_their_summary(tmp_path, capsys):
    built_kit()
    path = write_instance(tiny_instance(), tmp_path / "instance" / "tiny.json")
    status = startkit.main(["run", str(path), "--kit", str(KIT), "--ticks", "40", "--out",
                            str(tmp_path / "out")])  # fmt: skip
    printed = capsys.readouterr().out
    assert status == 0, printed
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    runs = {run["name"]: run for run in summary["runs"]}
    assert set(runs) == {"ours", "default", "simulate"}
    assert runs["ours"]["refused_motions"] == 0
    assert runs["simulate"]["refused_motions"] == 0
    assert "run" in printed
    assert "simulate" in printed
    for name in ("ours.json", "default.json", "simulate", "summary.json"):
        assert (tmp_path / "out" / name).exists()
    assert (summary["planner"], summary["scheduler"]) == ("guided-ops-repair", "assignment")


def test_the_command_runs_the_entry_and_simulate_with_the_same_scheduler(
    capped_kit_run, capsys, monkeypatch
):
    _, argv, out, status = capped_kit_run  # --only ours: the kit's run of the entry
    assert status == 0
    # The fixture's setting, its share included: a folder holds the runs of one setting.
    for name, value in UNBOUNDED.items():
        monkeypatch.setenv(name, value)
    # simulate replays the delays of ours
    assert startkit.main([*argv, "--only", "simulate"]) == 0, capsys.readouterr().out
    assert "the entry's guided-ops-repair and assignment-capped" in capsys.readouterr().out
    runs = json.loads((out / "summary.json").read_text())["runs"]
    assert [run["name"] for run in runs] == ["ours", "simulate"]  # the summary keeps both
    assert runs[0]["build"]
    assert "build" not in runs[1]
    kit = read_output(out / "ours.json")
    ours = read_output(out / "simulate" / "lorr-output.json")
    assert kit.data["numTaskFinished"] > 0
    late = np.flatnonzero((kit.planned == TIMEOUT).all(axis=0))
    same = kit.actual.shape[1] if not len(late) else int(late[0])
    assert (ours.actual[:, :same] == kit.actual[:, :same]).all()


def test_the_entrys_guidance_reaches_the_kits_planner_as_simulates(tmp_path, capsys, monkeypatch):
    built_kit()
    for name, value in UNBOUNDED.items():
        monkeypatch.setenv(name, value)
    instance = station_instance()
    path = write_instance(instance, tmp_path / "instance" / "stations.json")
    out = tmp_path / "out"
    guidance = {"vertex_weight": 2.0, "iterations": 0}  # heavy traffic prices, no repair
    argv = ["run", str(path), "--kit", str(KIT), "--ticks", "120", "--out", str(out),
            "--guidance", json.dumps(guidance)]  # fmt: skip
    for only in ("ours", "simulate"):  # simulate replays the delays of ours
        assert startkit.main([*argv, "--only", only]) == 0, capsys.readouterr().out
    assert json.loads((out / "summary.json").read_text())["guidance"] == guidance
    assert json.loads((out / "simulate" / "summary.json").read_text())["guidance"] == guidance
    kit = read_output(out / "ours.json")
    ours = read_output(out / "simulate" / "lorr-output.json")
    late = np.flatnonzero((kit.planned == TIMEOUT).all(axis=0))
    same = kit.actual.shape[1] if not len(late) else int(late[0])
    assert (ours.actual[:, :same] == kit.actual[:, :same]).all()
    # The entry's own fields plan otherwise on the same delays: the kit took the guidance.
    recorded = kit.actual.shape[1]
    plain = KitSystem(instance, delays=DelayReplay(kit.data["delayIntervals"], recorded))
    plain.run(recorded)
    paths = np.stack([decode_path(p, 100)[0] for p in plain.output().actual_paths])
    assert (paths[:, :same] != kit.actual[:, :same]).any()
