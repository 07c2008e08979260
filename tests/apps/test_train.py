"""``python -m warehouse_phys.train`` as users run it: real subprocesses, files, exit codes."""

import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from PIL import Image, ImageSequence

import warehouse_phys
from warehouse_phys import train as train_cli
from warehouse_phys.apps.train import FLEET_EPISODES
from warehouse_phys.rl.qlearning import check_training_memory, load_q_table, table_tail

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def run_cli(*args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "warehouse_phys.apps.train", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
    )


def gif_frames(path):
    """The frames of a GIF file as RGB arrays, and each one's delay in ms."""
    with Image.open(path) as image:
        assert image.format == "GIF"
        frames, delays = [], []
        for frame in ImageSequence.Iterator(image):
            frames.append(np.asarray(frame.convert("RGB")))
            delays.append(frame.info["duration"])
    return frames, delays


def assert_run_folder(folder, env_id, grid=(4, 5), episodes=1000, gif=True):
    names = sorted(p.name for p in folder.iterdir())
    expected = ["learning_curve.png", "qtable.npz", "summary.json"]
    assert names == sorted([*expected, "episode.gif"] if gif else expected)
    assert (folder / "learning_curve.png").read_bytes()[:8] == PNG_MAGIC
    q, metadata = load_q_table(folder / "qtable.npz")
    assert q.shape == (*grid, *grid, 4)
    assert (metadata["env_id"], metadata["grid_rows"], metadata["grid_cols"]) == (env_id, *grid)
    assert metadata["episodes"] == episodes
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["env_id"] == env_id
    assert summary["grid"] == list(grid)
    assert summary["config"]["episodes"] == episodes
    assert summary["training"]["episodes"] == episodes
    assert summary["training"]["reached_target"] + summary["training"]["truncated"] == episodes
    if gif:
        assert summary["files"]["episode_gif"] == "episode.gif"
        frames, _ = gif_frames(folder / "episode.gif")
        assert frames[0].shape == (grid[0] * 64 + 24, grid[1] * 64, 3)
        steps = summary["gif_episode"]["steps"]
        if env_id.startswith("warehouse-robot-phys"):  # smooth: several frames per move
            assert len(frames) > 4 * steps
        else:  # one jump per step
            assert len(frames) == steps + 1
    else:
        assert "episode_gif" not in summary["files"]
        assert "gif_episode" not in summary
    return q, summary


# -------------------------------------------------------------- the main job
@pytest.mark.slow
def test_no_arguments_trains_the_physics_environment_and_proves_the_policy(tmp_path):
    result = run_cli(cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stderr == ""  # no progress bar when stderr is not a terminal
    (folder,) = (tmp_path / "runs").iterdir()
    assert folder.name.startswith("phys-seed0-")
    _, summary = assert_run_folder(folder, warehouse_phys.PHYSICS_ENV_ID)
    assert summary["evaluation"]["all_optimal"] is True
    assert summary["evaluation"]["targets"] == 12
    lines = result.stdout.splitlines()
    assert lines[0].startswith("trained 1000 episodes on warehouse-robot-phys-v0 (4x5)")
    assert lines[1].split() == ["target", "steps", "optimal", "result"]
    assert sum(line.endswith("shortest path") for line in lines) == 13
    assert "all 12 targets reached by a shortest path" in lines


@pytest.mark.slow
def test_full_default_run_on_the_grid_twin(tmp_path):
    result = run_cli("--env", "grid", "--out", "my-run", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    _, summary = assert_run_folder(tmp_path / "my-run", warehouse_phys.GRID_ENV_ID)
    evaluation = summary["evaluation"]
    assert evaluation["all_optimal"] is True
    for entry in evaluation["results"]:
        assert entry["steps"] == entry["optimal_steps"] == sum(entry["target"])
    # (A saved table evaluated again from its file, by a process of its own: test_train_eval.py.)


def test_small_physics_run_without_a_gif_writes_the_rest_and_evaluates(tmp_path):
    # One process for two things a user asks of a small run: the options reach the run,
    # and --no-gif leaves the animation out (the GIFs of both worlds are checked by the
    # two default runs above).
    result = run_cli(
        "--env", "phys", "--rows", "3", "--cols", "3", "--episodes", "300", "--seed", "4",
        "--alpha", "0.8", "--gamma", "0.95", "--no-gif", "--out", "out", cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    _, summary = assert_run_folder(
        tmp_path / "out", warehouse_phys.PHYSICS_ENV_ID, grid=(3, 3), episodes=300, gif=False
    )
    assert summary["config"] == {"episodes": 300, "alpha": 0.8, "gamma": 0.95, "seed": 4}
    assert summary["evaluation"]["targets"] == 4
    assert summary["evaluation"]["all_optimal"] is True
    assert (
        result.stdout.splitlines()[-1]
        == "wrote out/qtable.npz, learning_curve.png and summary.json"
    )


def test_the_gif_replays_the_greedy_episode_of_the_seed(tmp_path):
    assert train_cli.main(
        ["--env", "grid", "--episodes", "300", "--seed", "5", "--quiet", "--out", str(tmp_path)]
    ) == 0  # fmt: skip
    summary = json.loads((tmp_path / "summary.json").read_text())
    q, _ = load_q_table(tmp_path / "qtable.npz")
    env = gym.make(warehouse_phys.GRID_ENV_ID, render_mode="rgb_array")
    obs, _ = env.reset(seed=5)
    expected = [env.render()]
    terminated = False
    while not terminated:
        obs, _, terminated, _, _ = env.step(int(q[tuple(obs)].argmax()))
        expected.append(env.render())
    assert summary["gif_episode"] == {
        "seed": 5, "target": obs[2:].tolist(), "steps": len(expected) - 1, "reached_target": True
    }  # fmt: skip
    frames, delays = gif_frames(tmp_path / "episode.gif")
    assert len(frames) == len(expected)
    for frame, want in zip(frames, expected, strict=True):
        # One palette for 256 colours: a close copy of each rendered frame, not an exact one.
        assert np.abs(frame.astype(int) - want).mean() < 2
    # Real time at the grid twin's 4 fps, the start held 0.5 s and the end 1 s.
    assert delays == [750] + [250] * (len(frames) - 2) + [1250]


def test_default_run_folders_do_not_collide(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    noon = time.strptime("2026-01-01 12:00:00", "%Y-%m-%d %H:%M:%S")
    monkeypatch.setattr(train_cli.time, "localtime", lambda *_: noon)  # two runs, same second
    for _ in range(2):  # no GIF: only the folders' names are checked
        assert train_cli.main(["--env", "grid", "--episodes", "20", "--quiet", "--no-gif"]) == 0
    names = sorted(p.name for p in (tmp_path / "runs").iterdir())
    assert names == ["grid-seed0-20260101-120000", "grid-seed0-20260101-120000-2"]


# --------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--episodes", "0"], "argument --episodes: expected a positive number of episodes, got 0"),
        (["--episodes", "-3"], "expected a positive number of episodes, got -3"),
        (["--episodes", "many"], "expected a positive number of episodes, got 'many'"),
        (["--rows", "1"], "argument --rows: expected 2 to 2048 rows, got 1"),
        (["--cols", "0"], "argument --cols: expected 2 to 2048 columns, got 0"),
        (["--alpha", "0"], r"argument --alpha: expected a number in \(0, 1\], got 0"),
        (["--alpha", "1.5"], r"expected a number in \(0, 1\], got 1.5"),
        (["--gamma", "-0.1"], r"argument --gamma: expected a number in \[0, 1\], got -0.1"),
        (["--gamma", "1.0000001"], r"expected a number in \[0, 1\], got 1\.0000001$"),
        (["--seed", "-1"], "argument --seed: expected a non-negative integer seed, got -1"),
        (["--env", "mujoco"], "argument --env: invalid choice: 'mujoco'"),
        (["--eval", "missing.npz"], "--eval: missing.npz: no such file"),
        (["--eval", "notes.txt"], "--eval: notes.txt: not an .npz archive"),
        (["--out", "notes.txt"], "--out notes.txt exists and is not a folder"),
        (["--frobnicate"], "unrecognized arguments: --frobnicate"),
        (["--layout", "office"], "--layout 'office' is neither a preset .* nor a file"),
        (["--layout", "notes.txt"], "--layout notes.txt: unknown layout symbol 'n' at row 0"),
        (["--layout", "maze", "--rows", "3"], "--rows and --cols come from the layout"),
    ],
)
def test_bad_arguments_exit_2_with_one_line_and_write_nothing(tmp_path, monkeypatch, capsys,
                                                              args, message):  # fmt: skip
    monkeypatch.chdir(tmp_path)
    (tmp_path / "notes.txt").write_text("not a table\n")
    assert train_cli.main(args) == 2
    out, err = capsys.readouterr()
    assert out == ""
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("python -m warehouse_phys.train: error: ")
    assert re.search(message, lines[0]), lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_bad_arguments_from_a_real_shell_give_no_traceback(tmp_path):
    result = run_cli("--episodes", "0", cwd=tmp_path)
    assert result.returncode == 2
    assert result.stdout == ""
    assert result.stderr == (
        "python -m warehouse_phys.train: error: argument --episodes: "
        "expected a positive number of episodes, got 0\n"
    )
    corrupt = tmp_path / "q.npz"
    corrupt.write_bytes(b"PK\x03\x04" + b"\x00" * 40)
    result = run_cli("--eval", "q.npz", cwd=tmp_path)
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert result.stderr.startswith("python -m warehouse_phys.train: error: --eval: q.npz: ")
    assert len(result.stderr.splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["q.npz"]


def test_help_lists_every_option(capsys):
    with pytest.raises(SystemExit) as exit_info:
        train_cli.main(["--help"])
    assert exit_info.value.code == 0
    text = capsys.readouterr().out
    for option in ("--env", "--episodes", "--seed", "--rows", "--cols", "--alpha", "--gamma",
                   "--out", "--render", "--eval", "--quiet"):  # fmt: skip
        assert option in text


# ------------------------------------------------------------------ --render
def test_render_watches_one_greedy_episode_in_a_window(tmp_path, monkeypatch):
    made = []
    real_make = gym.make

    def recording_make(*args, **kwargs):
        env = real_make(*args, **kwargs)
        made.append((kwargs.get("render_mode"), env))
        return env

    monkeypatch.setattr(gym, "make", recording_make)
    steps = []
    real_step = warehouse_phys.WarehouseEnvBase.step

    def recording_step(self, action):
        result = real_step(self, action)
        if self.render_mode == "human":
            steps.append(result)
        return result

    monkeypatch.setattr(warehouse_phys.WarehouseEnvBase, "step", recording_step)
    args = ["--env", "phys", "--rows", "3", "--cols", "3", "--episodes", "300", "--quiet",
            "--render", "--out", str(tmp_path / "run")]  # fmt: skip
    assert train_cli.main(args) == 0
    # Training, the GIF's episode, then the window.
    assert [mode for mode, _ in made] == [None, "rgb_array", "human"]
    # The greedy episode walked straight to the target and ended there.
    assert steps[-1][2] is True
    assert len(steps) == steps[0][4]["optimal_steps"] + 1
    assert np.isclose(steps[-1][1], 1.0)


# ------------------------------------------------------------------- --layout
@pytest.mark.slow
def test_a_preset_layout_trains_with_its_recommended_episodes(tmp_path, capsys):
    result = run_cli("--env", "grid", "--layout", "maze", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    (folder,) = (tmp_path / "runs").iterdir()
    assert folder.name.startswith("grid-maze-seed0-")
    episodes = warehouse_phys.PRESETS["maze"].training_episodes
    _, summary = assert_run_folder(
        folder, "warehouse-robot-maze-v0", grid=(5, 7), episodes=episodes
    )
    assert summary["layout_name"] == "maze"
    assert summary["evaluation"]["all_optimal"] is True
    assert "all 23 targets reached by a shortest path" in result.stdout.splitlines()
    # Evaluated again from the file, on the physics-backed twin of the preset: in this
    # process, which need not import the package afresh (--eval in a shell is
    # test_train_eval.py's).
    assert train_cli.main(["--eval", str(folder / "qtable.npz"), "--env", "phys"]) == 0
    again = capsys.readouterr().out
    assert "on warehouse-robot-phys-maze-v0" in again.splitlines()[0]
    assert "all 23 targets reached by a shortest path" in again


def test_a_layout_file_trains_and_its_table_remembers_the_layout(tmp_path, monkeypatch, capsys):
    (tmp_path / "room.txt").write_text("\nS..#\n.#..\n...P\n\n")
    result = run_cli("--env", "phys", "--layout", "room.txt", "--episodes", "200", "--out", "r",
                     cwd=tmp_path)  # fmt: skip
    assert result.returncode == 0, result.stderr
    _, summary = assert_run_folder(
        tmp_path / "r", warehouse_phys.PHYSICS_ENV_ID, grid=(3, 4), episodes=200
    )
    assert summary["layout"] == ["S..#", ".#..", "...P"]
    assert summary["layout_name"] is None
    assert summary["evaluation"]["results"] == [{"target": [2, 3], "steps": 5, "optimal_steps": 5}]
    assert "the target reached by a shortest path" in result.stdout
    # Without the file, --eval rebuilds the floor from the table (in this process, which
    # never read the file: the run above was another one).
    (tmp_path / "room.txt").unlink()
    monkeypatch.chdir(tmp_path)
    assert train_cli.main(["--eval", "r/qtable.npz", "--env", "grid"]) == 0
    assert "the target reached by a shortest path" in capsys.readouterr().out


# ------------------------------------------------------------- floors and limits
def test_every_floor_gets_its_suggested_time_limit_and_a_hint_when_it_falls_short(tmp_path, capsys):
    # 6 x 6 and 30 episodes (was 10 x 10 and 150: 30 times the steps): a floor that is not
    # the default one, with a limit of its own, and too few episodes to learn it. The limit
    # of every floor size is test_layouts.py's (10 x 10's 1,200 among them).
    out = tmp_path / "run"
    args = ["--env", "grid", "--rows", "6", "--cols", "6", "--episodes", "30", "--no-gif",
            "--out", str(out)]  # fmt: skip
    assert train_cli.main(args) == 0
    stdout = capsys.readouterr().out.splitlines()
    assert stdout[0].endswith("were truncated at 400 steps")  # the exact 98 % limit of 6 x 6
    summary = json.loads((out / "summary.json").read_text())
    assert summary["max_episode_steps"] == 400
    missed = 25 - summary["evaluation"]["reached"]
    assert missed > 0
    hints = [line for line in stdout if line.startswith("the greedy policy misses")]
    assert hints == [
        f"the greedy policy misses {missed} of 25 targets: try more episodes "
        "(--episodes 120) or a longer time limit (--max-steps 800)"
    ]


def test_max_steps_sets_the_time_limit_and_is_recorded(tmp_path, capsys):
    out = tmp_path / "run"
    args = ["--env", "grid", "--episodes", "40", "--max-steps", "5", "--no-gif", "--quiet",
            "--out", str(out)]  # fmt: skip
    assert train_cli.main(args) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["max_episode_steps"] == 5
    assert summary["training"]["total_steps"] <= 5 * 40
    assert summary["training"]["truncated"] > 0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--rows", "300", "--cols", "300"],
         r"a 300x300 floor needs a Q-table of 241\.4 GiB and 1000 episodes need .* more than "
         r"the 2\.0 GiB"),
        (["--episodes", "999999999999"], r"and 999999999999 episodes need 23\.6 TiB of records"),
        (["--rows", "100000"], "argument --rows: expected 2 to 2048 rows, got 100000"),
        (["--max-steps", "0"], "argument --max-steps: expected a positive number of steps, got 0"),
        (["--out", ""], "argument --out: expected a folder, got an empty path"),
    ],
)  # fmt: skip
def test_runs_too_big_for_memory_are_refused_before_anything_is_allocated(
    tmp_path, monkeypatch, capsys, args, message
):
    monkeypatch.chdir(tmp_path)
    assert train_cli.main(["--env", "grid", *args]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert len(err.splitlines()) == 1
    assert re.search(message, err), err
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------ run folders
SMALL_RUN = ["--env", "grid", "--episodes", "30", "--no-gif", "--quiet"]


def test_a_folder_holding_a_run_is_refused_unless_overwritten(tmp_path, capsys):
    out = tmp_path / "run"
    assert train_cli.main(["--env", "grid", "--episodes", "30", "--quiet", "--out", str(out)]) == 0
    assert (out / "episode.gif").exists()
    assert train_cli.main([*SMALL_RUN, "--seed", "5", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "holds an earlier run (episode.gif, learning_curve.png, qtable.npz, summary.json)" in err
    assert "--overwrite" in err
    assert train_cli.main([*SMALL_RUN, "--seed", "5", "--out", str(out), "--overwrite"]) == 0
    # Only the new run's files: the old GIF is gone, the table and summary agree.
    assert sorted(p.name for p in out.iterdir()) == [
        "learning_curve.png", "qtable.npz", "summary.json"
    ]  # fmt: skip
    _, metadata = load_q_table(out / "qtable.npz")
    assert metadata["seed"] == json.loads((out / "summary.json").read_text())["config"]["seed"] == 5


def test_a_folder_with_other_files_is_never_used(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("mine")
    for extra in ([], ["--overwrite"]):
        assert train_cli.main([*SMALL_RUN, "--out", str(tmp_path), *extra]) == 2
        assert "is not empty (notes.txt)" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_a_folder_in_use_by_another_run_is_refused(tmp_path, capsys):
    from warehouse_phys.files.runfolder import RunFolder

    out = tmp_path / "run"
    with RunFolder(out, train_cli.RUN_FILES):  # another run holds it
        assert train_cli.main([*SMALL_RUN, "--out", str(out), "--overwrite"]) == 2
    assert "is in use by another run" in capsys.readouterr().err
    assert train_cli.main([*SMALL_RUN, "--out", str(out)]) == 0  # free again


@pytest.mark.slow
def test_two_quiet_trainers_racing_for_one_folder_never_mix_their_files(tmp_path):
    out = tmp_path / "run"
    command = [sys.executable, "-m", "warehouse_phys.apps.train", *SMALL_RUN, "--out", str(out)]
    pipes = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, "text": True}
    runs = [subprocess.Popen([*command, "--seed", str(s)], cwd=tmp_path, **pipes) for s in (1, 2)]
    codes, outputs = [], []
    for run in runs:
        outputs.append(run.communicate(timeout=120))
        codes.append(run.returncode)
    assert sorted(codes) == [0, 2]
    winner = 1 + codes.index(0)
    # SMALL_RUN is --quiet: the run that trained and wrote its files printed nothing.
    assert outputs[winner - 1] == ("", "")
    _, metadata = load_q_table(out / "qtable.npz")
    assert metadata["seed"] == winner
    assert json.loads((out / "summary.json").read_text())["config"]["seed"] == winner


def test_leftover_temporary_files_are_removed_by_the_next_run(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / ".qtable.npz.k1ll3d.tmp").write_bytes(b"")  # what a killed run leaves
    (out / ".summary.json.x.tmp").write_bytes(b"{")
    assert train_cli.main([*SMALL_RUN, "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [
        "learning_curve.png", "qtable.npz", "summary.json"
    ]  # fmt: skip


def test_the_folder_is_created_and_proven_writable_before_training(tmp_path, monkeypatch):
    out = tmp_path / "deep" / "run"
    import warehouse_phys.apps.runs as runs

    real_train = runs.train

    def checking_train(*args, **kwargs):
        assert out.is_dir()
        assert list(out.iterdir()) == []  # the probe file is gone again
        return real_train(*args, **kwargs)

    monkeypatch.setattr(runs, "train", checking_train)
    assert train_cli.main([*SMALL_RUN, "--out", str(out)]) == 0


def test_a_failed_write_exits_1_naming_the_file_and_keeps_the_complete_ones(
    tmp_path, monkeypatch, capsys
):
    import errno

    import warehouse_phys.viz.figures as plots

    def disk_full(figure, path):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(plots, "save_figure", disk_full)
    out = tmp_path / "run"
    assert train_cli.main([*SMALL_RUN, "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err == (
        f"python -m warehouse_phys.train: error: cannot write {out / 'learning_curve.png'}: "
        f"No space left on device (qtable.npz is complete in {out})\n"
    )
    assert sorted(p.name for p in out.iterdir()) == ["qtable.npz"]
    load_q_table(out / "qtable.npz")


@pytest.mark.parametrize("where", ["training", "writing"])
def test_an_interruption_says_what_was_written(tmp_path, monkeypatch, capsys, where):
    import warehouse_phys.apps.runs as runs
    import warehouse_phys.viz.figures as plots

    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(*((runs, "train") if where == "training" else (plots, "save_figure")),
                        interrupt)  # fmt: skip
    out = tmp_path / "run"
    assert train_cli.main([*SMALL_RUN, "--out", str(out)]) == 130
    err = capsys.readouterr().err
    if where == "training":
        assert err == "python -m warehouse_phys.train: interrupted; nothing was written\n"
        assert not out.exists()  # the folder this run created is gone again
    else:
        assert err == (
            f"python -m warehouse_phys.train: interrupted; qtable.npz is complete in {out}\n"
        )


@pytest.mark.parametrize("folder", ["/proc/warehouse_phys_run", "/sys/warehouse_phys_run"])
def test_an_unwritable_folder_exits_1_in_one_line_before_training(tmp_path, folder):
    result = run_cli(*SMALL_RUN, "--out", folder, cwd=tmp_path)
    assert result.returncode == 1
    assert result.stdout == ""
    assert result.stderr.startswith(
        f"python -m warehouse_phys.train: error: cannot write {folder}: "
    )
    assert len(result.stderr.splitlines()) == 1


# ------------------------------------------------------------------ no display
def without_display():
    env = dict(os.environ)
    for name in ("SDL_VIDEODRIVER", "DISPLAY", "WAYLAND_DISPLAY"):
        env.pop(name, None)
    return env


@pytest.mark.slow
def test_render_without_a_display_exits_1_before_training(tmp_path):
    started = time.monotonic()
    result = subprocess.run(
        [sys.executable, "-m", "warehouse_phys.apps.train", *SMALL_RUN, "--render"],
        cwd=tmp_path, capture_output=True, text=True, env=without_display(), timeout=60,
    )  # fmt: skip
    assert time.monotonic() - started < 30
    assert result.returncode == 1
    assert result.stderr.startswith(
        "python -m warehouse_phys.train: error: cannot open a window: there is no display"
    )
    assert "xvfb-run" in result.stderr
    assert len(result.stderr.splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------- a fleet
@pytest.mark.slow
def test_a_fleet_trains_writes_its_run_and_is_evaluated_against_shortest_paths(
    tmp_path, monkeypatch, capsys
):
    # 200 episodes: 60 delivered (400: 58); what is checked is the run, its files and --eval.
    result = run_cli("--robots", "3", "--env", "grid", "--episodes", "200", "--out", "fleet",
                     cwd=tmp_path)  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "trained 3 robots sharing one table" in result.stdout
    table = result.stdout.split("one package per robot:\n")[1].splitlines()
    assert [line.split()[0] for line in table[:4]] == ["learned", "shortest", "random", "pibt"]
    assert "0 moves refused by traffic" in table[3]  # the planner's plans are all granted
    folder = tmp_path / "fleet"
    assert sorted(p.name for p in folder.iterdir()) == [
        "episode.gif", "learning_curve.png", "qtable.npz", "summary.json",
    ]  # fmt: skip
    q, metadata = load_q_table(folder / "qtable.npz")
    assert q.shape == (4, 5, 4, 5, 5)
    assert metadata["robots"] == 3
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["robots"] == 3
    for policy in ("learned", "shortest_path"):
        evaluation = summary["evaluation"][policy]
        assert evaluation["episodes"] == 20
        assert evaluation["delay"] == evaluation["robot_steps"] - evaluation["shortest_steps"]
    frames, _ = gif_frames(folder / "episode.gif")
    assert frames[0].shape == (4 * 64 + 24, 5 * 64, 3)
    learned = summary["evaluation"]["learned"]
    assert learned["delivered"] > 30  # of 60
    # What the training taught: random walks deliver 58 of 60 packages too, but at a sum of
    # costs of 3,324 against the learned table's 653 (an untrained table walks at random).
    costs = {line.split()[0]: int(line.split("sum of costs ")[1].split()[0]) for line in table[:4]}
    assert costs["learned"] == learned["sum_of_costs"]
    assert costs["learned"] < costs["random"] / 2, costs
    # The file read back and evaluated again: in this process, which need not import the
    # package afresh (the run above is the user's; --eval in a shell is test_train_eval.py's).
    monkeypatch.chdir(tmp_path)
    assert train_cli.main(["--eval", "fleet/qtable.npz"]) == 0
    again = capsys.readouterr().out
    assert "(3 robots, warehouse-robot-v0, 4x5, 200 episodes" in again
    assert f"{learned['delivered']}/60 packages delivered" in again


def test_a_physics_fleet_run_writes_its_files(tmp_path, capsys):
    # (the fleet's smooth GIF frames are checked in tests/rl/test_fleet_learning.py)
    folder = tmp_path / "fleet"
    args = ["--robots", "2", "--env", "phys", "--rows", "2", "--cols", "3", "--episodes", "5",
            "--max-steps", "20"]  # fmt: skip
    assert train_cli.main([*args, "--out", str(folder), "--quiet", "--no-gif"]) == 0
    assert capsys.readouterr().out == ""
    assert sorted(p.name for p in folder.iterdir()) == [
        "learning_curve.png", "qtable.npz", "summary.json",
    ]  # fmt: skip
    summary = json.loads((folder / "summary.json").read_text())
    assert (summary["env_id"], summary["max_cycles"]) == ("warehouse-robot-phys-v0", 20)
    assert load_q_table(folder / "qtable.npz")[0].shape == (2, 3, 2, 3, 5)
    assert set(summary["evaluation"]) >= {"learned", "shortest_path", "random", "pibt"}


def test_a_neighbours_fleet_table_is_written_read_back_and_evaluated(tmp_path, capsys):
    folder = tmp_path / "fleet"
    args = ["--robots", "2", "--env", "grid", "--rows", "2", "--cols", "3", "--episodes", "30",
            "--observation", "neighbours", "--out", str(folder), "--quiet", "--no-gif"]  # fmt: skip
    assert train_cli.main(args) == 0
    q, metadata = load_q_table(folder / "qtable.npz")
    assert q.shape == (2, 3, 2, 3, 16, 5)
    assert (metadata["robots"], metadata["observation"]) == (2, "neighbours")
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["training"]["max_steps"] == summary["max_cycles"]  # below 200 steps
    assert summary["evaluation"]["learned_patience"] >= 1
    capsys.readouterr()
    assert train_cli.main(["--eval", str(folder / "qtable.npz")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "(2 robots, warehouse-robot-v0, 2x3, 30 episodes" in lines[0]
    assert [line.split()[0] for line in lines[1:5]] == ["learned", "shortest", "random", "pibt"]
    with pytest.raises(SystemExit):
        train_cli.main(["--help"])
    assert "--observation {local,neighbours}" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--robots", "0"], "expected a number of robots from 1 to 10,000, got 0"),
        # The physics world holds what the memory does: the floor's room is what refuses.
        (["--robots", "10000"], "10000 robots need 10000 start cells; this floor has 20"),
        (
            [
                "--env",
                "grid",
                "--robots",
                "2",
                "--rows",
                "43",
                "--cols",
                "43",
                "--observation",
                "neighbours",
            ],
            "a 43x43 floor needs a Q-table of 2.04 GiB",
        ),
        (["--robots", "3", "--render"], "--render shows one robot in a window"),
        (["--robots", "7", "--layout", "depot"], "7 robots need 7 package cells"),
        (["--observation", "neighbours"], "it needs --robots 2 or more"),
        (["--robots", "2", "--observation", "global"], "invalid choice: 'global'"),
        (["--eval", "x.npz", "--observation", "local"], "leave out --out, --observation"),
        (["--eval", "x", "--episodes", "5", "--robots", "2"], "out --episodes, --out, --robots"),
    ],
)
def test_a_fleet_that_cannot_be_trained_exits_2_and_writes_nothing(tmp_path, capsys, args, message):
    assert train_cli.main([*args, "--out", str(tmp_path / "out")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_the_limits_page_names_the_largest_square_floors_train_accepts(tmp_path, capsys):
    limits = (Path(__file__).parents[2] / "docs" / "limits.md").read_text()
    row = next(line for line in limits.splitlines() if line.startswith("| training memory |"))
    sides = [int(side) for side in re.findall(r"(\d+) x \1", row)]
    assert len(sides) == 3, row
    for (robots, observation), side in zip(
        [(1, None), (2, "local"), (2, "neighbours")], sides, strict=True
    ):
        tail = table_tail({"robots": robots, "observation": observation})
        episodes = 1000 if robots == 1 else FLEET_EPISODES
        check_training_memory(side, side, episodes, tail=tail)  # fits
        fleet = ["--robots", "2", "--observation", observation] if observation else []
        larger = str(side + 1)
        args = ["--env", "grid", "--rows", larger, "--cols", larger, *fleet]
        assert train_cli.main([*args, "--out", str(tmp_path / "out")]) == 2
        assert f"a {larger}x{larger} floor needs a Q-table" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_the_gif_of_a_large_floor_is_drawn_with_cells_that_fit_its_frame():
    """A 90 x 90 floor's GIF was drawn at 64 px a cell: 100 MB frames, 17 GB at the peak
    (the run was killed); its cells now shrink so that a frame is at most 1,024 px (down to
    the renderer's 16 px a cell), and a large floor's GIF has fewer steps (128 MiB)."""
    import numpy as np

    from warehouse_phys.apps.runs import GIF_FRAME_BYTES, GIF_FRAME_PX, Floor, greedy_episode

    episode = greedy_episode(Floor(rows=20, cols=20), "grid", np.zeros((20, 20, 20, 20, 4)),
                             seed=0)  # fmt: skip
    height, width = episode.frames[0].shape[:2]
    assert width <= GIF_FRAME_PX  # the floor; below it, the status line
    assert height <= GIF_FRAME_PX + 24
    table = np.broadcast_to(np.zeros(4), (90, 90, 90, 90, 4))  # a table of no memory
    big = greedy_episode(Floor(rows=90, cols=90), "grid", table, seed=0)
    assert big.frames[0].shape[1] == 90 * 16  # the least cell
    assert sum(frame.nbytes for frame in big.frames) <= GIF_FRAME_BYTES
    small = greedy_episode(Floor(rows=4, cols=5), "grid", np.zeros((4, 5, 4, 5, 4)), seed=0)
    assert small.frames[0].shape[1] == 5 * 64  # small floors as ever
