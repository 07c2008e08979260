"""The folder of ``startkit run``: when a run may write into a folder holding an earlier
one, what it removes first, and which of the earlier summary's runs stay."""

import json

import pytest

from warehouse_phys.lorr.startkit.run_folder import (
    SUMMARY,
    RunFolderRefused,
    prepare_folder,
    run_files,
)
from warehouse_phys.lorr.startkit.runs import RUNS

SETTING = {"instance": "x.json", "ticks": 40, "kit": "kit", "planner": "guided-ops-repair",
           "scheduler": "assignment", "guidance": {}, "round_share": 0.6}  # fmt: skip


def earlier_run(folder, names=RUNS, setting=SETTING):
    """A folder as a run of ``names`` of ``setting`` leaves it."""
    folder.mkdir(exist_ok=True)
    for name in names:
        for file in run_files(name):
            path = folder / file
            if file in ("simulate", f".{name}-kit"):
                path.mkdir()
                (path / "inside.json").write_text("{}")
            else:
                path.write_text(name)
    runs = [{"name": name, "tasks_finished": 7} for name in names]
    (folder / SUMMARY).write_text(json.dumps({**setting, "robots": 4, "runs": runs}))
    return folder


def test_a_missing_or_empty_folder_is_used_as_it_is(tmp_path):
    assert prepare_folder(tmp_path / "new", RUNS, SETTING, overwrite=False) == []
    assert not (tmp_path / "new").exists()  # nothing created
    assert prepare_folder(tmp_path, RUNS, SETTING, overwrite=False) == []


@pytest.mark.parametrize("overwrite", [False, True])
def test_a_file_the_command_does_not_write_is_refused_and_kept(tmp_path, overwrite):
    earlier_run(tmp_path)
    (tmp_path / "notes.txt").write_text("mine")
    (tmp_path / ".DS_Store").write_text("")  # hidden: not in the way
    with pytest.raises(RunFolderRefused, match=r"holds 'notes\.txt', which this command does not"):
        prepare_folder(tmp_path, RUNS, SETTING, overwrite=overwrite)
    assert (tmp_path / "notes.txt").read_text() == "mine"
    assert (tmp_path / "ours.json").is_file()
    with pytest.raises(RunFolderRefused, match="not a folder"):
        prepare_folder(tmp_path / "notes.txt", RUNS, SETTING, overwrite=overwrite)


def test_all_three_into_an_earlier_run_need_overwrite_which_removes_it_all(tmp_path):
    earlier_run(tmp_path)
    before = sorted(path.name for path in tmp_path.iterdir())
    with pytest.raises(RunFolderRefused, match=r"holds an earlier run \(default.json.*"
                                               r"pass --overwrite"):  # fmt: skip
        prepare_folder(tmp_path, RUNS, SETTING, overwrite=False)
    assert sorted(path.name for path in tmp_path.iterdir()) == before  # nothing touched
    assert prepare_folder(tmp_path, RUNS, SETTING, overwrite=True) == []
    assert list(tmp_path.iterdir()) == []


def test_one_run_joins_an_earlier_run_of_its_setting_and_the_summary_keeps_it(tmp_path):
    earlier_run(tmp_path, names=("ours",))
    kept = prepare_folder(tmp_path, ["simulate"], SETTING, overwrite=False)
    assert kept == [{"name": "ours", "tasks_finished": 7}]
    assert (tmp_path / "ours.json").read_text() == "ours"  # the delays simulate replays


def test_one_run_already_there_is_replaced_only_with_overwrite(tmp_path):
    earlier_run(tmp_path)
    with pytest.raises(RunFolderRefused, match=r"an earlier simulate run \(simulate"):
        prepare_folder(tmp_path, ["simulate"], SETTING, overwrite=False)
    assert (tmp_path / "simulate" / "inside.json").is_file()
    kept = prepare_folder(tmp_path, ["simulate"], SETTING, overwrite=True)
    assert [run["name"] for run in kept] == ["ours", "default"]
    assert not (tmp_path / "simulate").exists()
    assert not (tmp_path / "simulate.log").exists()
    for name in ("ours.json", "ours.log", "default.json", ".ours-kit", SUMMARY):
        assert (tmp_path / name).exists(), name


@pytest.mark.parametrize("field", ["instance", "ticks", "kit", "planner", "scheduler",
                                   "guidance", "round_share"])  # fmt: skip
def test_a_folder_never_holds_runs_of_two_settings(tmp_path, field):
    earlier_run(tmp_path, names=("ours",))
    others = {"ticks": 80, "guidance": {"reroute": 32}, "round_share": None}
    other = {**SETTING, field: others.get(field, "other")}
    with pytest.raises(RunFolderRefused, match=f"a run of another setting \\({field} "):
        prepare_folder(tmp_path, ["simulate"], other, overwrite=False)
    assert (tmp_path / "ours.json").is_file()
    assert prepare_folder(tmp_path, ["simulate"], other, overwrite=True) == []
    assert list(tmp_path.iterdir()) == []  # the other setting's run is gone


@pytest.mark.parametrize("summary", ["{not json", "[]", '{"runs": [{"name": "kit"}]}'])
def test_an_earlier_run_without_its_summary_is_not_joined(tmp_path, summary):
    earlier_run(tmp_path, names=("ours",))
    (tmp_path / SUMMARY).write_text(summary)
    with pytest.raises(RunFolderRefused, match=r"an earlier run without its summary\.json"):
        prepare_folder(tmp_path, ["simulate"], SETTING, overwrite=False)
    assert prepare_folder(tmp_path, ["simulate"], SETTING, overwrite=True) == []
    assert list(tmp_path.iterdir()) == []


def test_an_earlier_summary_without_the_round_share_was_the_default_share(tmp_path):
    """Summaries written before the share was a setting: their entries' rounds were bounded
    at the default share, so a run at that share joins them and one without a bound not."""
    earlier_run(tmp_path, names=("ours",), setting={
        k: v for k, v in SETTING.items() if k != "round_share"})  # fmt: skip
    assert prepare_folder(tmp_path, ["simulate"], SETTING, overwrite=False) != []
    with pytest.raises(RunFolderRefused, match=r"another setting \(round_share 0\.6, not None"):
        prepare_folder(tmp_path, ["simulate"], {**SETTING, "round_share": None}, overwrite=False)
