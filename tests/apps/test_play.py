"""``python -m warehouse_phys.play``: keyboard driving, tested headless with posted events."""

import gymnasium as gym
import numpy as np
import pygame
import pytest

import warehouse_phys
from tests.drawing.test_render import robot_centre
from warehouse_phys import Action
from warehouse_phys import play as play_cli
from warehouse_phys.apps import interrupts
from warehouse_phys.apps.play import HUD_LINE_PX, HUD_LINES, FleetPlaySession, PlaySession
from warehouse_phys.envs import fleet
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.world.traffic import WAIT

GRID_ID = warehouse_phys.GRID_ENV_ID
PHYS_ID = warehouse_phys.PHYSICS_ENV_ID


def key(k):
    return pygame.event.Event(pygame.KEYDOWN, key=k)


def post(*events):
    for event in events:
        pygame.event.post(event)


@pytest.fixture
def session_of():
    """Sessions made here are closed after the test, whatever happens."""
    sessions = []

    def make(env_id=GRID_ID, seed=0, **kwargs):
        env = gym.make(env_id, render_mode="rgb_array", **kwargs)
        session = PlaySession(env, seed=seed)
        sessions.append(session)
        return session

    yield make
    for session in sessions:
        session.close()


def window_pixels():
    return pygame.surfarray.array3d(pygame.display.get_surface()).transpose(1, 0, 2)


def test_the_window_shows_the_frame_and_three_lines_of_counters(session_of):
    session = session_of()
    frame = session.env.render()
    assert window_pixels().shape == (frame.shape[0] + HUD_LINES * HUD_LINE_PX, frame.shape[1], 3)
    assert np.array_equal(window_pixels()[: frame.shape[0]], frame)
    assert session.hud_lines() == [
        "step 0   reward 0   return 0",
        "episode 1: drive to the package",
        "arrows drive   R new episode   Esc quits",
    ]


def test_arrow_keys_drive_the_robot_like_the_actions(session_of):
    session = session_of(seed=0)  # package on (3, 3)
    reference = gym.make(GRID_ID)
    reference.reset(seed=0)
    for k, action in [(pygame.K_RIGHT, Action.RIGHT), (pygame.K_DOWN, Action.DOWN),
                      (pygame.K_UP, Action.UP), (pygame.K_LEFT, Action.LEFT),
                      (pygame.K_UP, Action.UP)]:  # fmt: skip
        session.handle(key(k))
        expected, *_ = reference.step(action)
        assert session.obs.tolist() == expected.tolist()
    assert session.steps == 5
    assert session.hud_lines()[0] == "step 5   reward 0   return 0"
    assert np.array_equal(window_pixels()[: 4 * 64 + 24], session.env.render())


def test_other_keys_and_events_do_nothing(session_of):
    session = session_of()
    session.handle(key(pygame.K_a))
    session.handle(pygame.event.Event(pygame.KEYUP, key=pygame.K_RIGHT))
    session.handle(pygame.event.Event(pygame.MOUSEBUTTONDOWN, button=1, pos=(5, 5)))
    assert (session.steps, session.obs.tolist()[:2], session.running) == (0, [0, 0], True)


def test_reaching_the_package_shows_the_reward_and_the_next_arrow_starts_over(session_of):
    session = session_of(seed=0)  # package on (3, 3): six steps away
    for k in [pygame.K_RIGHT] * 3 + [pygame.K_DOWN] * 3:
        session.handle(key(k))
    assert session.terminated
    assert session.hud_lines()[:2] == [
        "step 6   reward 1   return 1",
        "Delivered in 6 steps: a shortest path!",
    ]
    session.handle(key(pygame.K_LEFT))  # no move: a new episode
    assert (session.episodes, session.steps, session.terminated) == (2, 0, False)
    assert session.obs.tolist()[:2] == [0, 0]
    # The second episode continues the first one's random stream.
    reference = gym.make(GRID_ID)
    reference.reset(seed=0)
    second, _ = reference.reset()
    assert session.obs.tolist() == second.tolist()


def test_a_detour_is_counted_against_the_shortest_path(session_of):
    session = session_of(seed=0)
    for k in [pygame.K_UP] + [pygame.K_RIGHT] * 3 + [pygame.K_DOWN] * 3:
        session.handle(key(k))
    assert session.hud_lines()[1] == "Delivered in 7 steps: 1 more than the shortest"


def test_the_time_limit_ends_an_episode(session_of):
    session = session_of(max_episode_steps=2)
    session.handle(key(pygame.K_UP))
    session.handle(key(pygame.K_UP))
    assert session.truncated
    assert session.hud_lines()[1] == "Time is up after 2 steps"
    session.handle(key(pygame.K_UP))
    assert (session.episodes, session.steps) == (2, 0)


def test_r_starts_a_new_episode_at_any_time(session_of):
    session = session_of()
    session.handle(key(pygame.K_RIGHT))
    session.handle(key(pygame.K_r))
    assert (session.episodes, session.steps, session.obs.tolist()[:2]) == (2, 0, [0, 0])


def test_the_physics_plays_the_move_as_motion(session_of, monkeypatch):
    session = session_of(PHYS_ID)
    centres = []
    real_draw = PlaySession._draw

    def spy(self):
        real_draw(self)
        centres.append(robot_centre(window_pixels()))

    monkeypatch.setattr(PlaySession, "_draw", spy)
    session.handle(key(pygame.K_RIGHT))
    # 14 frames during the move, then the snapped one: the body drives across.
    assert len(centres) == 15
    columns = [col for _, col in centres]
    assert columns == sorted(columns)
    assert columns[0] < 0.3
    assert 0.3 < columns[5] < 0.9
    assert columns[-1] == pytest.approx(1, abs=0.02)
    assert session.obs.tolist()[:2] == [0, 1]


def test_run_handles_posted_keys_until_escape_then_closes(session_of):
    session = session_of(seed=0)
    post(key(pygame.K_RIGHT), key(pygame.K_DOWN), key(pygame.K_ESCAPE), key(pygame.K_RIGHT))
    session.run()
    assert session.obs.tolist()[:2] == [1, 1]  # the key after Escape was never handled
    assert session.steps == 2
    assert not session.running
    assert not pygame.display.get_init()


def test_closing_the_window_quits(session_of):
    session = session_of()
    post(key(pygame.K_DOWN), pygame.event.Event(pygame.QUIT))
    session.run()
    assert session.steps == 1
    assert not pygame.display.get_init()


def test_a_session_needs_rgb_array_frames():
    with pytest.raises(ValueError, match="render_mode='rgb_array', not 'ansi'"):
        PlaySession(gym.make(GRID_ID, render_mode="ansi"))


# ------------------------------------------------------------- command line
def test_main_drives_the_chosen_floor_and_exits_cleanly(monkeypatch):
    steps = []
    real_step = PlaySession.step
    monkeypatch.setattr(
        PlaySession, "step", lambda self, action: (steps.append(action), real_step(self, action))
    )
    made = []
    real_init = PlaySession.__init__

    def init(self, env, **kwargs):
        made.append((env.spec.id, env.unwrapped.grid_rows, env.unwrapped.grid_cols, kwargs))
        real_init(self, env, **kwargs)

    monkeypatch.setattr(PlaySession, "__init__", init)
    pygame.display.init()
    post(key(pygame.K_RIGHT), key(pygame.K_DOWN), pygame.event.Event(pygame.QUIT))
    assert play_cli.main(["--env", "grid", "--rows", "3", "--cols", "6", "--seed", "4"]) == 0
    assert steps == [Action.RIGHT, Action.DOWN]
    assert made == [
        (GRID_ID, 3, 6, {"seed": 4, "title": "python -m warehouse_phys.play: warehouse-robot-v0"})
    ]
    assert not pygame.display.get_init()


def test_main_defaults_to_the_physics_and_takes_a_layout(monkeypatch):
    made = []
    monkeypatch.setattr(PlaySession, "run", lambda self: made.append(self.env.spec.id))
    assert play_cli.main(["--layout", "maze"]) == 0
    assert play_cli.main([]) == 0
    assert made == ["warehouse-robot-phys-maze-v0", PHYS_ID]
    pygame.display.quit()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--env", "box"], "argument --env: invalid choice: 'box'"),
        (["--rows", "1"], "argument --rows: expected 2 to 2048 rows, got 1"),
        (["--seed", "-3"], "argument --seed: expected a non-negative integer seed, got -3"),
        (["--layout", "nowhere"], "--layout 'nowhere' is neither a preset"),
        (["--layout", "maze", "--cols", "4"], "--rows and --cols come from the layout"),
        (["--episodes", "3"], "unrecognized arguments: --episodes 3"),
        (["--rows", "512"], "frames of 320x32792 pixels, more than a window can draw"),
    ],
)
def test_bad_arguments_exit_2_with_one_line_and_no_window(args, message, capsys):
    assert play_cli.main(args) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert len(err.splitlines()) == 1
    assert err.startswith("python -m warehouse_phys.play: error: ")
    assert message in err
    assert not pygame.display.get_init()


def test_no_display_exits_1_with_the_reason(monkeypatch, capsys):
    def no_display(*_args, **_kwargs):
        raise pygame.error("No available video device")

    monkeypatch.setattr(pygame.display, "set_mode", no_display)
    assert play_cli.main(["--env", "grid"]) == 1
    _, err = capsys.readouterr()
    assert err == (
        "python -m warehouse_phys.play: error: cannot open a window (No available video device)\n"
    )
    assert not pygame.display.get_init()


def test_the_counters_change_when_the_motion_has_played(session_of, monkeypatch):
    session = session_of(PHYS_ID, grid_rows=2, grid_cols=2)  # the package is on (1, 1)
    session.handle(key(pygame.K_RIGHT))
    hud_during_move = []
    real_draw = PlaySession._draw

    def spy(self):
        real_draw(self)
        hud_during_move.append(self.hud_lines())

    monkeypatch.setattr(PlaySession, "_draw", spy)
    session.handle(key(pygame.K_DOWN))  # onto the package
    *moving, arrived = hud_during_move
    assert len(moving) == 14
    for lines in moving:  # the robot is still on its way: last step's counters, no verdict
        assert lines[0] == "step 1   reward 0   return 0"
        assert not lines[1].startswith("Delivered")
    assert arrived[0] == "step 2   reward 1   return 1"
    assert arrived[1] == "Delivered in 2 steps: a shortest path!"


@pytest.mark.slow
def test_the_real_command_without_a_display_exits_1_at_once(tmp_path):
    import os
    import subprocess
    import sys
    import time

    env = {k: v for k, v in os.environ.items()
           if k not in ("SDL_VIDEODRIVER", "DISPLAY", "WAYLAND_DISPLAY")}  # fmt: skip
    started = time.monotonic()
    result = subprocess.run(
        [sys.executable, "-m", "warehouse_phys.apps.play", "--env", "grid"],
        cwd=tmp_path, capture_output=True, text=True, env=env, timeout=60,
    )  # fmt: skip
    assert time.monotonic() - started < 30
    assert result.returncode == 1
    assert result.stdout == ""
    assert result.stderr == (
        "python -m warehouse_phys.play: error: cannot open a window: there is no display "
        "(DISPLAY and WAYLAND_DISPLAY are unset); run it in a desktop session, forward one "
        "with `ssh -X`, or start a virtual one with `xvfb-run`; rgb_array rendering needs no "
        "display\n"
    )


def test_sdls_invisible_drivers_count_as_no_display(monkeypatch):
    from warehouse_phys.drawing.display import NoDisplayError, check_display

    monkeypatch.delenv("SDL_VIDEODRIVER")
    monkeypatch.setenv("DISPLAY", ":99")  # set, but SDL found nothing there

    class FakeDisplay:
        get_init = staticmethod(lambda: True)
        get_driver = staticmethod(lambda: "offscreen")

    class FakePygame:
        display = FakeDisplay

    with pytest.raises(NoDisplayError, match="chose its 'offscreen' driver, which shows nothing"):
        check_display(FakePygame)
    check_display()  # a DISPLAY alone passes the first check


# ------------------------------------------------------------------- a fleet
@pytest.fixture
def fleet_session():
    sessions = []

    def make(robots=3, seed=0, **kwargs):
        env = fleet.parallel_env(num_robots=robots, render_mode="rgb_array", **kwargs)
        session = FleetPlaySession(env, seed=seed)
        sessions.append(session)
        return session

    yield make
    for session in sessions:
        session.close()


def test_a_person_drives_robot_0_while_the_others_follow_the_planner(fleet_session):
    session = fleet_session(seed=0)
    reference = fleet.parallel_env(num_robots=3)
    reference.reset(seed=0)
    planner = PIBT(reference.grid, distances=reference.distances, seed=0)
    assert session.hud_lines() == [
        "step 0   delivered 0/3",
        "episode 1: drive the red robot to the red package",
        "arrows drive   space waits   R new episode   Esc quits",
    ]
    for k, action in [(pygame.K_RIGHT, Action.RIGHT), (pygame.K_SPACE, WAIT),
                      (pygame.K_DOWN, Action.DOWN)]:  # fmt: skip
        session.handle(key(k))
        live = reference.on_floor & ~reference.parked
        planned = planner.plan(reference.robot_cells, reference.package_cells, live,
                               reference.on_floor, requests={0: int(action)})  # fmt: skip
        actions = {a: int(planned[i]) for i, a in enumerate(reference.possible_agents)
                   if a in reference.agents}  # fmt: skip
        actions["robot_0"] = int(action)
        reference.step(actions)
        assert np.array_equal(session.env.state(), reference.state())
    assert session.steps == 3
    assert np.array_equal(window_pixels()[: 4 * 64 + 24], session.env.render())


def test_the_planner_moves_teammates_out_of_the_persons_way():
    env = fleet.parallel_env(num_robots=2, grid_rows=3, grid_cols=4)
    env.reset(seed=0)
    env._cells = np.array([(1, 0), (1, 1)])  # robot_1 stands right of robot_0
    env._packages = np.array([(1, 3), (2, 0)])  # and wants to go the other way
    planner = PIBT(env.grid, distances=env.distances, seed=0)
    for _ in range(3):  # the person keeps pressing RIGHT
        planned = planner.plan(env.robot_cells, env.package_cells, requests={0: 2})
        actions = {"robot_0": 2, "robot_1": int(planned[1])}
        if "robot_1" not in env.agents:
            del actions["robot_1"]
        _, _, _, _, infos = env.step(actions)
        assert not infos["robot_0"]["refused"]
    assert env.robot_cells[0].tolist() == [1, 3]


def test_a_fleet_episode_ends_when_every_package_is_delivered(fleet_session):
    session = fleet_session(robots=2, seed=1)
    for _ in range(60):
        if session.episode_over:
            break
        row, col, p_row, p_col = session.env.state()[:4]
        toward = (pygame.K_DOWN if row < p_row else pygame.K_UP if row > p_row
                  else pygame.K_RIGHT if col < p_col else pygame.K_LEFT)  # fmt: skip
        session.handle(key(toward if "robot_0" in session.env.agents else pygame.K_SPACE))
    assert session.terminated
    assert session.delivered == 2
    assert session.hud_lines()[1] == f"Every package delivered in {session.steps} steps"
    session.handle(key(pygame.K_RIGHT))  # the next key starts over
    assert (session.episodes, session.steps, session.delivered) == (2, 0, 0)


def test_the_fleets_physics_plays_as_motion(fleet_session, monkeypatch):
    session = fleet_session(physics=True)
    drawn = []
    monkeypatch.setattr(session, "_draw", lambda: drawn.append(session._frame))
    session.handle(key(pygame.K_RIGHT))
    assert len(drawn) == 15  # 14 frames of motion, then the snapped frame


def test_main_plays_a_fleet_and_refuses_one_too_big_for_the_floor(monkeypatch, capsys):
    made = []
    monkeypatch.setattr(FleetPlaySession, "run", lambda self: made.append(self.env.num_robots))
    assert play_cli.main(["--robots", "4", "--env", "grid"]) == 0
    assert made == [4]
    assert play_cli.main(["--robots", "9", "--rows", "2", "--cols", "2"]) == 2
    assert "9 robots need 9 start cells" in capsys.readouterr().err
    pygame.display.quit()


@pytest.mark.parametrize(("stop", "status"), [(KeyboardInterrupt, 130), (None, 143)])
def test_ctrl_c_and_sigterm_close_the_window_and_exit_130_and_143(monkeypatch, stop, status):
    """Ctrl-C (KeyboardInterrupt) or SIGTERM (sent to this process while the session
    runs) closes the session and exits 130 or 143, as train and simulate do."""
    import os
    import signal

    closed = []

    def run(self):
        if stop is None:
            os.kill(os.getpid(), signal.SIGTERM)  # raised as interrupts.Terminated right here
        raise stop()

    monkeypatch.setattr(PlaySession, "run", run)
    monkeypatch.setattr(PlaySession, "close", lambda self: closed.append(True))
    assert play_cli.main(["--env", "grid"]) == status
    assert closed == [True]
    assert signal.getsignal(signal.SIGTERM) is not interrupts._terminate  # put back
