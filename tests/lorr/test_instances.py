"""League of Robot Runners instances: the published files, a round trip, and every fault."""

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, reject, settings
from hypothesis import strategies as st

from warehouse_phys.execution.delays import DelayConfig
from warehouse_phys.lorr.instances import (
    PUBLISHED_FIGURES,
    LorrInstance,
    read_instance,
    write_instance,
)
from warehouse_phys.world.grid import WarehouseGrid

#: The competition's instances beside the repository, absent on a fresh clone.
LORR = Path(__file__).resolve().parents[3] / "shared" / "lorr"

#: A valid delayConfig: LoRR requires all eight fields.
DELAYS = {"seed": 0, "minDelay": 1, "maxDelay": 4, "eventModel": "poisson", "pDelay": 0.1,
          "durationModel": "uniform", "gaussMeanRatio": 0.5, "gaussStdRatio": 0.25}  # fmt: skip


def needs_lorr() -> None:
    if not LORR.is_dir():
        pytest.skip(f"LoRR instances not found at {LORR} (the shared folder beside the checkout)")


@pytest.mark.parametrize(
    ("relative", "robots", "tasks", "assignment", "year", "stops"),
    [
        ("2023-main-warehouse/MR23-I-10.json", 10_000, 500_000, "roundrobin", 2023, 1),
        ("2023-examples-warehouse/EI23-warehouse_large_200.json", 200, 500_000, "roundrobin",
         2023, 1),
        ("2024-main-warehouse/WAREHOUSE.json", 10_000, 100_000, "scheduler", 2024, 2),
        ("2026-examples-random/random-example_400.json", 400, 3200, "scheduler", 2026, 4),
        ("2026-examples-maze/maze-example_40.json", 40, 160, "scheduler", 2026, 2),
    ],
)  # fmt: skip
def test_the_published_instances_read_as_the_competition_reads_them(
    relative, robots, tasks, assignment, year, stops
):
    needs_lorr()
    instance = read_instance(LORR / relative)
    assert (instance.team_size, instance.num_tasks) == (robots, tasks)
    assert (instance.assignment, instance.year) == (assignment, year)
    assert instance.stops_per_task.max() == stops
    assert len(np.unique(instance.starts)) == robots
    grid = instance.grid
    first = (LORR / relative).parent / json.loads((LORR / relative).read_text())["taskFile"]
    lines = [line for line in first.read_text().splitlines() if not line.startswith("#")]
    assert instance.task(0).tolist() == [int(v) for v in lines[1].split(",")]
    assert instance.task(tasks - 1).tolist() == [int(v) for v in lines[tasks].split(",")]
    for location in (*instance.starts[:50], *instance.task_stops[:50]):
        assert divmod(int(location), grid.cols) not in grid.shelves


def test_the_2024_instance_opens_one_and_a_half_tasks_a_robot_and_2026_keeps_its_delays():
    needs_lorr()
    warehouse = read_instance(LORR / "2024-main-warehouse/WAREHOUSE.json")
    assert warehouse.open_tasks == 15_000
    random = read_instance(LORR / "2026-examples-random/random-example_400.json")
    assert random.agent_counter == 3
    assert random.agent_size == 1.0
    assert random.delay == DelayConfig(0, 1, 4, "bernoulli", 0.01, "uniform", 0.5, 0.22)
    assert PUBLISHED_FIGURES["MR23-I-10"].best == 38.9
    assert PUBLISHED_FIGURES["WAREHOUSE"].default == 12.78


FLOOR = ["....#", ".#...", "....."]


def write_files(folder, *, data=None, agents="3\n0\n2\n14\n", tasks="2\n3\n13\n", grid=FLOOR):
    """An instance's four files in ``folder``; returns the JSON's path."""
    (folder / "maps").mkdir(exist_ok=True)
    (folder / "maps/f.map").write_text(
        f"type octile\nheight {len(grid)}\nwidth {len(grid[0])}\nmap\n"
        + "".join(row.replace("#", "@") + "\n" for row in grid)
    )
    (folder / "a.agents").write_text(agents)
    (folder / "t.tasks").write_text(tasks)
    base = {"mapFile": "maps/f.map", "agentFile": "a.agents", "taskFile": "t.tasks",
            "teamSize": 3, "numTasksReveal": 1, "taskAssignmentStrategy": "roundrobin"}  # fmt: skip
    (folder / "x.json").write_text(json.dumps(base if data is None else {**base, **data}))
    return folder / "x.json"


def test_a_small_instance_reads_with_comments_and_blank_lines_at_the_end(tmp_path):
    path = write_files(tmp_path, agents="# version for LoRR 2023\n3\n0\n# a note\n2\n14\n\n\n",
                       tasks="2\n3\n13,0\n# more\n")  # fmt: skip
    instance = read_instance(path)
    assert instance.starts.tolist() == [0, 2, 14]
    assert [instance.task(t).tolist() for t in range(2)] == [[3], [13, 0]]
    assert instance.name == "x"
    assert instance.path == path


def test_only_the_teams_starts_are_read(tmp_path):
    # A start file may hold more starts than the team: the competition reads the team's.
    path = write_files(tmp_path, agents="5\n0\n2\n14\nnot a number\n\x00\x01")
    assert read_instance(path).starts.tolist() == [0, 2, 14]


BAD_JSON = [
    ("[1, 2]", "must be a JSON object"),
    ("{", "not JSON"),
    ('{"mapFile": "m"}', "missing 'agentFile'"),
]


@pytest.mark.parametrize(("text", "message"), BAD_JSON)
def test_a_json_that_is_no_instance_is_refused_in_one_line(tmp_path, text, message):
    path = write_files(tmp_path)
    if text.startswith('{"mapFile"'):
        data = json.loads(path.read_text())
        del data["agentFile"]
        text = json.dumps(data)
    path.write_text(text)
    with pytest.raises(ValueError, match=message) as error:
        read_instance(path)
    assert "\n" not in str(error.value)
    assert str(path) in str(error.value)


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"teamSize": "ten"}, "teamSize must be a number"),
        ({"teamSize": 0}, "teamSize must be 1 to"),
        ({"teamSize": 2.5}, "teamSize must be a whole number"),
        ({"numTasksReveal": 0}, "numTasksReveal must be above 0"),
        ({"taskAssignmentStrategy": "magic"}, "taskAssignmentStrategy must be one of"),
        ({"version": "1999 LoRR"}, "unknown version '1999 LoRR'"),
        ({"agentCounter": 0}, "agentCounter must be 1 to"),
        ({"agentSize": 2.0}, "agentSize must be above 0 and at most 1"),
        ({"delayConfig": 3}, "delayConfig must be an object"),
        ({"delayConfig": {"seed": 0}}, "missing 'minDelay'"),
        ({"delayConfig": {**DELAYS, "minDelay": 5, "maxDelay": 1}},
         r"max_delay \(delayConfig.maxDelay\) must be at least min_delay \(5\), got 1"),
        ({"delayConfig": {**DELAYS, "minDelay": 0}}, r"min_delay \(delayConfig.minDelay\)"),
        ({"delayConfig": {**DELAYS, "eventModel": "storm"}},
         "event_model .* must be one of bernoulli, poisson; got 'storm'"),
        ({"delayConfig": {**DELAYS, "pDelay": 1.5}}, r"pDelay\) must be in \[0, 1\], got 1.5"),
        ({"delayConfig": {k: v for k, v in DELAYS.items() if k != "gaussStdRatio"}},
         "delayConfig is missing 'gaussStdRatio'"),
        ({"mapFile": "nowhere.map"}, "no such map file"),
        ({"agentFile": "nowhere"}, "no such start file"),
        ({"taskFile": "maps"}, "not a regular file, no task file"),
    ],
)  # fmt: skip
def test_every_bad_field_is_refused_in_one_line_naming_it(tmp_path, data, message):
    with pytest.raises(ValueError, match=message) as error:
        read_instance(write_files(tmp_path, data=data))
    assert "\n" not in str(error.value)


@pytest.mark.parametrize(
    ("files", "message"),
    [
        ({"agents": ""}, r"a\.agents: no count of starts \(the file is empty\)"),
        ({"agents": "three\n0\n"}, r"a\.agents, line 1: expected the number of starts"),
        ({"agents": "2\n0\n2\n"}, r"teamSize is 3 but .*a\.agents has 2 starts"),
        ({"agents": "3\n0\n2\n"}, r"a\.agents, line 4: the count says 3 starts, the file has 2"),
        ({"agents": "3\n0\nx7\n1\n"}, r"a\.agents, line 3: a start must be locations .* 'x7'"),
        ({"agents": "3\n0\n2\n99\n"}, r"a\.agents, line 4: location 99 is off the map"),
        ({"agents": "3\n0\n4\n2\n"}, r"1 starts on blocked cells, the first 4 \(row 0, col 4\)"),
        ({"agents": "3\n0\n2\n0\n"}, r"1 start cells hold two robots .*robots 0 and 2"),
        ({"tasks": "0\n"}, r"t\.tasks, line 1: the file holds no task"),
        ({"tasks": "3\n1\n2\n"}, r"t\.tasks, line 4: the count says 3 tasks, the file has 2"),
        ({"tasks": "2\n1\n2,,3\n"}, r"t\.tasks, line 3: a task must be .* got 'nothing'"),
        ({"tasks": "2\n1\n-3\n"}, r"t\.tasks, line 3: location -3 is off the map"),
        ({"tasks": "2\n1\n3,6\n"}, r"1 task stops on blocked cells, the first 6 \(row 1, col 1\)"),
        ({"tasks": "2\n1\n\n2\n"}, r"t\.tasks, line 3: a task must be .* got 'nothing'"),
    ],
)
def test_every_fault_of_a_start_or_task_file_names_its_file_and_line(tmp_path, files, message):
    with pytest.raises(ValueError, match=message) as error:
        read_instance(write_files(tmp_path, **files))
    assert "\n" not in str(error.value)


def test_a_team_larger_than_the_start_files_count_is_refused_with_both_counts(tmp_path):
    path = write_files(tmp_path, data={"teamSize": 7})
    with pytest.raises(ValueError, match=r"teamSize is 7 but .* has 3 starts"):
        read_instance(path)


@settings(max_examples=40)
@given(
    rows=st.integers(2, 6),
    cols=st.integers(2, 6),
    shelf_bits=st.integers(0, 2**36 - 1),
    year=st.sampled_from([2023, 2024, 2026]),
    data=st.data(),
)
def test_random_instances_round_trip(tmp_path_factory, rows, cols, shelf_bits, year, data):
    layout = ["".join("#" if (shelf_bits >> (r * 6 + c)) & 1 else "." for c in range(cols))
              for r in range(rows)]  # fmt: skip
    layout[0] = "." + layout[0][1:]
    try:
        grid = WarehouseGrid.from_layout(layout)
    except ValueError:  # no floor beside the start: no map
        reject()
    free = [r * cols + c for r in range(rows) for c in range(cols) if layout[r][c] == "."]
    starts = data.draw(st.lists(st.sampled_from(free), min_size=1, max_size=len(free),
                                unique=True))  # fmt: skip
    most = 1 if year == 2023 else 4
    tasks = data.draw(st.lists(st.lists(st.sampled_from(free), min_size=1, max_size=most),
                               min_size=1, max_size=30))  # fmt: skip
    offsets = np.cumsum([0] + [len(task) for task in tasks])
    delay = DelayConfig(3, 1, 5, "poisson", 0.25, "gaussian") if year == 2026 else None
    instance = LorrInstance(
        name="round", grid=grid, starts=starts, task_offsets=offsets,
        task_stops=[stop for task in tasks for stop in task],
        num_tasks_reveal=1.0 if year == 2023 else 1.5,
        assignment=data.draw(st.sampled_from(["roundrobin", "greedy"])) if year == 2023
        else "scheduler",
        version=None if year == 2023 else f"{year} LoRR",
        agent_counter=10 if year == 2026 else None, delay=delay,
    )  # fmt: skip
    folder = tmp_path_factory.mktemp("round")
    again = read_instance(write_instance(instance, folder / "round.json"))
    assert again.starts.tolist() == starts
    assert [again.task(t).tolist() for t in range(again.num_tasks)] == tasks
    assert again.grid.shelves == grid.shelves
    assert (again.grid.rows, again.grid.cols) == (rows, cols)
    for field in ("num_tasks_reveal", "assignment", "version", "agent_counter", "delay"):
        assert getattr(again, field) == getattr(instance, field)


def test_files_that_are_no_text_or_too_large_are_refused_in_one_line(tmp_path, monkeypatch):
    from warehouse_phys.lorr import instance_files

    path = write_files(tmp_path)
    path.write_bytes(b"\xff\xfe{}")
    with pytest.raises(ValueError, match="not UTF-8 text; not a LoRR instance"):
        read_instance(path)
    path = write_files(tmp_path)
    monkeypatch.setattr(instance_files, "MAX_LIST_BYTES", 8)
    with pytest.raises(
        ValueError, match=r"a\.agents: larger than any start file this reader takes"
    ):
        read_instance(path)


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"starts": []}, "no robot"),
        ({"task_offsets": [0, 1, 1]}, "every task needs at least one stop"),
        ({"task_offsets": [0, 1, 3]}, "task_offsets end at 3, not at 2 stops"),
        ({"task_stops": [3, 99]}, "1 task stops off the 3 x 5 map, the first 99"),
        ({"starts": [0, -1]}, "1 starts off the 3 x 5 map, the first -1"),
        ({"assignment": "scheduler"}, "a scheduler assigns the tasks of 2024 and later, only"),
        ({"assignment": "auction"}, "unknown assignment 'auction'"),
    ],
)
def test_an_instance_built_in_memory_is_checked_as_a_read_one(fields, message):
    grid = WarehouseGrid.from_layout(FLOOR)
    kwargs = {"name": "mem", "grid": grid, "starts": [0, 2], "task_offsets": [0, 1, 2],
              "task_stops": [3, 13], **fields}  # fmt: skip
    with pytest.raises(ValueError, match=message):
        LorrInstance(**kwargs)


def test_unreadable_files_and_odd_values_are_refused_in_one_line(tmp_path, monkeypatch):
    path = write_files(tmp_path, data={"mapFile": ""})
    with pytest.raises(ValueError, match="mapFile must be a non-empty string, got ''"):
        read_instance(path)
    delays = {**DELAYS, "durationModel": "gaussian"}
    path = write_files(tmp_path)
    data = json.loads(path.read_text())
    path.write_text(json.dumps({**data, "delayConfig": delays})[:-1] + ', "x": NaN}')
    read_instance(path)  # an unknown key is ignored, as the competition does
    text = json.dumps({**data, "delayConfig": {**delays, "gaussStdRatio": 0.125}})
    path.write_text(text.replace("0.125}", "NaN}"))
    with pytest.raises(
        ValueError, match=r"gauss_std_ratio \(delayConfig.gaussStdRatio\) must be finite"
    ):
        read_instance(path)

    def refuse(self, *args, **kwargs):
        raise PermissionError(13, "Permission denied")

    path = write_files(tmp_path)
    monkeypatch.setattr(Path, "open", refuse)
    with pytest.raises(ValueError, match="cannot read the instance file: Permission denied"):
        read_instance(path)


def test_an_instance_on_a_map_wider_than_512_cells_reads(tmp_path):
    # orz900d, 656 x 1,491, was refused for its width before floors grew to 2,048 cells.
    wide = ["." * 1491, "." * 1490 + "#", "." * 1491]
    path = write_files(tmp_path, agents="3\n0\n1491\n4472\n", tasks="2\n1490\n2982,5\n", grid=wide)
    instance = read_instance(path)
    assert (instance.grid.rows, instance.grid.cols) == (3, 1491)
    assert instance.starts.tolist() == [0, 1491, 4472]
    with pytest.raises(ValueError, match=r"task stops on blocked cells, the first 2981"):
        read_instance(write_files(tmp_path, tasks="1\n2981\n", grid=wide))


def test_an_instance_map_longer_than_its_header_says_is_refused_with_the_headers_size(tmp_path):
    path = write_files(tmp_path)
    with (tmp_path / "maps/f.map").open("a") as map_file:
        map_file.write("." * 10_000)
    with pytest.raises(ValueError, match=r"f\.map: 10,\d{3} bytes, longer than 2 maps of 3 x 5"):
        read_instance(path)


def test_an_instance_whose_map_file_holds_its_map_twice_is_read_with_a_warning(tmp_path):
    # The 2023 examples' Paris maps: the competition reads `height` rows, ignores the rest.
    path = write_files(tmp_path)
    map_file = tmp_path / "maps/f.map"
    once = read_instance(path).grid.shelves
    map_file.write_text(map_file.read_text() * 2)
    with pytest.warns(UserWarning, match=r"f\.map: 7 lines after the header's 3 rows ignored"):
        assert read_instance(path).grid.shelves == once


HUGE = "1" + "0" * 400  # 401 digits


@pytest.mark.parametrize(
    ("field", "message"),
    [
        ("numTasksReveal", "numTasksReveal is out of range: an integer of 401 digits"),
        ("agentSize", "agentSize is out of range: an integer of 401 digits"),
        ("teamSize", "teamSize is out of range: an integer of 401 digits"),
        ("agentCounter", "agentCounter is out of range: an integer of 5,000 digits"),
    ],
)
def test_a_huge_integer_in_a_field_is_refused_naming_the_file_and_the_field(
    tmp_path, field, message
):
    path = write_files(tmp_path)
    digits = "7" * 5000 if "5,000" in message else HUGE
    path.write_text(path.read_text()[:-1] + f', "{field}": {digits}}}')
    with pytest.raises(ValueError, match=message) as error:
        read_instance(path)
    assert str(error.value).startswith(f"{path}: ")


def test_a_huge_p_delay_and_a_json_nested_deep_are_refused_naming_the_file(tmp_path):
    path = write_files(tmp_path)
    data = json.loads(path.read_text())
    path.write_text(json.dumps({**data, "delayConfig": {**DELAYS, "pDelay": 0}}).replace(
        '"pDelay": 0', f'"pDelay": {HUGE}'))  # fmt: skip
    with pytest.raises(ValueError, match=f"^{path}: delayConfig pDelay is out of range: an "
                                         "integer of 401 digits$"):  # fmt: skip
        read_instance(path)
    path.write_text('{"a": ' + "[" * 100_000 + "]" * 100_000 + "}")
    with pytest.raises(ValueError, match=f"^{path}: JSON nested too deeply"):
        read_instance(path)
    from warehouse_phys.execution.delays import DelayConfig

    with pytest.raises(ValueError, match=r"p_delay .* must be finite, got an integer of 1,329"):
        DelayConfig.from_json({**DELAYS, "pDelay": int(HUGE)})


@pytest.mark.parametrize("relative", ["../../../etc/passwd", "/etc/passwd", "maps/../../x.map"])
def test_a_file_outside_the_instances_folder_is_refused_unread(tmp_path, relative):
    inner = tmp_path / "inner"
    inner.mkdir()
    (tmp_path / "x.map").write_text("secret first line\n")
    path = write_files(inner, data={"mapFile": relative})
    with pytest.raises(ValueError, match=f"mapFile {relative!r} leads out of the instance's"):
        read_instance(path)
    write_files(inner, data={"agentFile": "maps/../a.agents"})  # inside, by a detour
    read_instance(inner / "x.json")


def test_a_start_line_of_two_locations_is_refused_naming_the_line(tmp_path):
    path = write_files(tmp_path, agents="3\n0\n2,3\n14\n")
    with pytest.raises(ValueError, match=r"a.agents, line 3: a start is one location "
                                         r"\(row \* width \+ col\), got '2,3'"):  # fmt: skip
        read_instance(path)
