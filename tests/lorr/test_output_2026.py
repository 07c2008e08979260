"""The 2026 output file: a file the start kit wrote read back and walked by the kit's rules,
segments written and read back, bad files refused in one line."""

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.lorr.tiny_kit_instance import TICKS, tiny_instance
from warehouse_phys.lorr.output_2026 import (
    KEYS,
    LETTERS,
    Output2026,
    SegmentedPaths,
    decode_path,
    read_output,
    walk,
    write_output,
)

GOLDEN = Path(__file__).with_name("data") / "kit_tiny_output.json"


def test_a_file_the_kit_wrote_reads_back_and_walks_by_its_rules():
    read = read_output(GOLDEN)
    data, instance = read.data, tiny_instance()
    assert list(data) == list(KEYS)  # the kit's keys, in the kit's order
    assert (data["version"], data["actionModel"], data["teamSize"]) == ("2026 LoRR", "MAPF_T", 8)
    assert (data["makespan"], data["agentMaxCounter"], data["outputSegmentSize"]) == (TICKS, 3, 100)
    # The kit waited for the entry's first plan (its Python starting up) some ticks that it
    # counts in makespan but does not record in the paths.
    recorded = read.actual.shape[1]
    late = TICKS - recorded
    assert read.actual.shape == read.planned.shape == (8, recorded)
    assert 0 <= late < 10
    cols = instance.grid.cols
    assert [r * cols + c for r, c, _ in data["start"]] == instance.starts.tolist()
    steps = walk(read, instance.grid)
    assert steps.collisions == []  # the kit refused no motion: our walk finds no collision
    # Every event is a robot standing on the errand it finished, at that tick.
    tasks = {task: stops for task, _, stops in data["tasks"]}
    for tick, robot, task, done in data["events"]:
        row, col = tasks[task][2 * (done - 1) : 2 * done]
        assert steps.cells[tick - late, robot] == row * cols + col
    finished = sum(1 for _, _, task, done in data["events"] if done == len(tasks[task]) // 2)
    assert finished == data["numTaskFinished"] > 0
    # A delayed robot does nothing: every delayed tick is a wait.
    for robot, pairs in enumerate(data["delayIntervals"]):
        for start, end in pairs:
            assert (read.actual[robot, start : min(end, recorded)] == LETTERS.index("W")).all()


@given(st.integers(1, 6), st.integers(0, 250), st.integers(1, 40), st.integers(0, 2**32 - 1))
def test_segments_written_read_back_to_the_same_actions(n, ticks, segment, seed):
    rng = np.random.default_rng(seed)
    actions = rng.integers(0, 5, size=(ticks, n)).astype(np.int8)
    actions[rng.random((ticks, n)) < 0.5] = 3  # runs of waits
    paths = SegmentedPaths(n, segment)
    for t in range(ticks):
        paths.add(actions[t], np.full(n, t % 7), np.arange(n), np.full(n, t % 4), np.zeros(n, int))
    for robot, text in enumerate(paths.strings()):
        decoded, headers = decode_path(text, segment)
        assert decoded.tolist() == actions[:, robot].tolist()
        assert [h[0] for h in headers] == list(range(0, ticks, segment))
        assert all(h[1:4] == (h[0] % 7, robot, h[0] % 4) for h in headers)


def test_a_written_file_is_one_line_in_the_kits_order_and_reads_back(tmp_path):
    paths = SegmentedPaths(2, 100)
    for t in range(5):
        paths.add(np.array([0, 3]), np.array([1, 2]), np.array([3, 4]), np.zeros(2, int),
                  np.array([t % 3, 0]))  # fmt: skip
    strings = paths.strings()
    output = Output2026(team_size=2, tasks_finished=0, ticks=5, agent_max_counter=3,
                        delay_intervals=[[[1, 3]], []], starts=[[1, 3], [2, 4]],
                        actual_paths=strings, planner_paths=strings)  # fmt: skip
    path = write_output(tmp_path / "out.json", output)
    assert path.read_text().count("\n") == 0
    read = read_output(path)
    assert list(read.data) == list(KEYS)
    assert read.actual.tolist() == [[0] * 5, [3] * 5]
    assert read.data["actualPaths"][0] == "[(0,1,3,0,0):(F 5)]"


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d.pop("agentMaxCounter"), "not a LoRR 2026 output file"),
        (lambda d: d.update(teamSize=0), "teamSize must be an integer of at least 1"),
        (lambda d: d["actualPaths"].pop(), "one string a robot"),
        (lambda d: d["actualPaths"].__setitem__(0, "[(0,1,1,0,0):(X 3)]"), "robot 0.*'X 3'"),
        (lambda d: d["actualPaths"].__setitem__(0, "[(5,1,1,0,0):(W 3)]"), "expected 0"),
        (lambda d: d["delayIntervals"].__setitem__(2, [[4, 2]]), "robot 2"),
    ],
)
def test_a_bad_file_is_refused_in_one_line_naming_it(tmp_path, change, message):
    data = json.loads(GOLDEN.read_text())
    change(data)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=message) as error:
        read_output(path)
    assert str(path) in str(error.value)
    assert "\n" not in str(error.value)


def test_a_missing_or_broken_file_is_one_line(tmp_path):
    for path, text in ((tmp_path / "none.json", None), (tmp_path / "broken.json", "{")):
        if text is not None:
            path.write_text(text)
        with pytest.raises(ValueError, match="not a readable JSON output file"):
            read_output(path)


def test_empty_segments_after_the_last_recorded_tick_are_read():
    # The kit writes them when it waited for a late entry without recording the ticks.
    text = "[(0,1,2,0,0):(F 3,W 97)][(100,1,3,0,0):(W 58)][(200,1,3,0,0):()][(300,1,3,0,0):()]"
    actions, headers = decode_path(text, 100)
    assert len(actions) == 158
    assert [h[0] for h in headers] == [0, 100, 200, 300]
    with pytest.raises(ValueError, match="follows a short one"):
        decode_path("[(0,1,2,0,0):(W 5)][(100,1,2,0,0):(W 5)]", 100)
