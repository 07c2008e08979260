"""Rendering: rgb_array frames, the human window and lazy pygame (the ansi picture is
tests/drawing/test_text_frames.py, the map frames tests/drawing/test_map_frames.py)."""

import gymnasium as gym
import numpy as np
import pytest

from warehouse_phys import PHYSICS_ENV_ID, Action, WarehouseGridEnv
from warehouse_phys import render as render_module
from warehouse_phys.drawing.render import WarehouseRenderer

ENV_ID = "warehouse-robot-v0"
CELL = 64


def robot_mask(frame):
    """Pixels of the robot's orange chassis (no other sprite has this colour)."""
    r, g, b = (frame[..., i].astype(int) for i in range(3))
    return (r > 220) & (g > 115) & (g < 170) & (b < 70)


def robot_centre(frame):
    """The centroid of the robot's chassis, in cell units (row, col), cell centres whole."""
    ys, xs = np.nonzero(robot_mask(frame))
    assert len(ys) > 200, "robot sprite not found in the frame"
    return ys.mean() / CELL - 0.5, xs.mean() / CELL - 0.5


def status_strip(env, frame):
    return frame[env.unwrapped.grid_rows * CELL :]


# ------------------------------------------------------------------- rgb_array
def test_rgb_array_frame_shape_and_dtype():
    env = gym.make(ENV_ID, render_mode="rgb_array", grid_rows=3, grid_cols=6)
    env.reset(seed=0)
    frame = env.render()
    renderer = env.unwrapped._renderer
    assert frame.dtype == np.uint8
    assert frame.shape == (3 * CELL + renderer.status_px, 6 * CELL, 3)
    assert frame.flags.c_contiguous
    assert frame is not env.render()


def test_robot_sprite_is_drawn_in_its_cell_and_moves_with_it():
    env = gym.make(ENV_ID, render_mode="rgb_array")
    env.reset(options={"target": (3, 4)})
    np.testing.assert_allclose(robot_centre(env.render()), (0, 0), atol=0.1)
    for action, cell in [(Action.DOWN, (1, 0)), (Action.RIGHT, (1, 1)), (Action.RIGHT, (1, 2))]:
        env.step(action)
        np.testing.assert_allclose(robot_centre(env.render()), cell, atol=0.1)
    # No chassis pixel outside the robot's cell.
    frame = env.render()
    outside = robot_mask(frame).copy()
    outside[1 * CELL : 2 * CELL, 2 * CELL : 3 * CELL] = False
    assert not outside.any()


def test_robot_is_drawn_at_continuous_positions_between_cells():
    renderer = WarehouseRenderer(4, 5)
    for position in [(0.5, 0.0), (1.0, 2.25), (2.75, 3.5)]:
        frame = renderer.rgb_array(position, (3, 4))
        np.testing.assert_allclose(robot_centre(frame), position, atol=0.05)


def test_package_is_drawn_on_the_target_cell():
    env = gym.make(ENV_ID, render_mode="rgb_array")
    env.reset(options={"target": (2, 3)})
    frame = env.render()
    empty_floor = frame[2 * CELL : 3 * CELL, 1 * CELL : 2 * CELL].astype(int)
    package_cell = frame[2 * CELL : 3 * CELL, 3 * CELL : 4 * CELL].astype(int)
    assert np.abs(package_cell - empty_floor).mean() > 20
    # Every other floor cell is the same tile.
    other_floor = frame[3 * CELL : 4 * CELL, 1 * CELL : 2 * CELL].astype(int)
    assert np.array_equal(empty_floor, other_floor)


@pytest.mark.parametrize("env_id", [ENV_ID, PHYSICS_ENV_ID])
def test_shelves_are_drawn_on_their_cells_with_the_shelf_sprite(env_id):
    import pygame

    env = gym.make(env_id, render_mode="rgb_array", layout=["S.#", "..#", "P.."])
    env.reset(seed=0)
    frame = env.render()

    def cell(r, c):
        return frame[r * CELL : (r + 1) * CELL, c * CELL : (c + 1) * CELL].astype(int)

    assert np.array_equal(cell(0, 2), cell(1, 2))  # both shelves, the same picture
    assert np.abs(cell(0, 2) - cell(1, 1)).mean() > 30  # unlike the floor
    assert np.array_equal(cell(1, 1), cell(2, 2))  # floor cells stay floor
    assert not robot_mask(cell(0, 2)).any()  # no orange on a shelf: the robot stays findable
    # It is the project's shelf sprite, drawn over a floor tile.
    sprite = pygame.image.load(str(render_module.sprite_path("shelf.png")))
    floor = pygame.image.load(str(render_module.sprite_path("floor.png")))
    tile = pygame.transform.smoothscale(floor, (CELL, CELL))
    tile.blit(pygame.transform.smoothscale(sprite, (CELL, CELL)), (0, 0))
    expected = pygame.surfarray.array3d(tile).transpose(1, 0, 2).astype(int)
    assert np.array_equal(cell(0, 2), expected)
    env.close()


def test_status_line_shows_the_last_action_and_is_empty_after_reset():
    env = gym.make(ENV_ID, render_mode="rgb_array")
    env.reset(seed=0)
    blank = status_strip(env, env.render())
    assert (blank == render_module.STATUS_BACKGROUND).all()
    strips = {}
    for action in (Action.LEFT, Action.DOWN, Action.RIGHT, Action.UP):
        env.step(action)
        strips[action] = status_strip(env, env.render())
        assert not (strips[action] == render_module.STATUS_BACKGROUND).all()
    assert len({strip.tobytes() for strip in strips.values()}) == 4
    assert env.unwrapped._status_text() == "Action: UP"
    env.reset()
    assert (status_strip(env, env.render()) == render_module.STATUS_BACKGROUND).all()


def test_status_text_fits_a_two_column_grid():
    renderer = WarehouseRenderer(2, 2)
    frame = renderer.rgb_array((0, 0), (1, 1), "Action: RIGHT")
    strip = frame[2 * CELL :]
    text_columns = np.nonzero((strip != render_module.STATUS_BACKGROUND).any(axis=(0, 2)))[0]
    assert text_columns.min() > 0
    assert text_columns.max() < 2 * CELL - 1


def test_cell_size_is_configurable():
    env = WarehouseGridEnv(render_mode="rgb_array", cell_px=32)
    env.reset(seed=0)
    assert env.render().shape[:2] == (4 * 32 + env._renderer.status_px, 5 * 32)
    for mode in (None, "ansi", "rgb_array", "human"):
        with pytest.raises(ValueError, match="cell_px must be at least 16"):
            WarehouseGridEnv(render_mode=mode, cell_px=8)
    with pytest.raises(TypeError, match="cell_px must be an integer"):
        WarehouseGridEnv(cell_px=64.0)


def test_rgb_array_never_opens_a_window():
    import pygame

    env = gym.make(ENV_ID, render_mode="rgb_array")
    env.reset(seed=0)
    env.step(Action.DOWN)
    env.render()
    assert not pygame.display.get_init() or pygame.display.get_surface() is None
    env.close()


def test_render_before_reset_raises():
    with pytest.raises(gym.error.ResetNeeded):
        WarehouseGridEnv(render_mode="rgb_array").render()


def test_render_without_mode_warns_and_returns_none():
    env = WarehouseGridEnv()
    env.reset(seed=0)
    with pytest.warns(UserWarning, match="without specifying any render mode"):
        assert env.render() is None


# ----------------------------------------------------------------------- human
def post(event_type, **fields):
    import pygame

    pygame.event.post(pygame.event.Event(event_type, **fields))


@pytest.mark.parametrize("env_id", [ENV_ID, PHYSICS_ENV_ID])
@pytest.mark.parametrize("how", ["quit", "escape"])
def test_closing_the_window_stops_drawing_but_not_the_program(how, env_id):
    import pygame

    env = gym.make(env_id, render_mode="human")
    env.reset(seed=0)
    status_px = env.unwrapped._renderer.status_px
    assert pygame.display.get_surface().get_size() == (5 * CELL, 4 * CELL + status_px)
    if how == "quit":
        post(pygame.QUIT)
    else:
        post(pygame.KEYDOWN, key=pygame.K_ESCAPE)
    obs, *_ = env.step(Action.DOWN)  # the step's render sees the event
    assert env.unwrapped.user_closed_window
    assert not pygame.display.get_init()
    # The environment keeps working without a window, and closes cleanly twice.
    obs, *_ = env.step(Action.RIGHT)
    assert obs[:2].tolist() == [1, 1]
    env.close()
    env.close()
    # A new environment can open a window afterwards.
    env2 = gym.make(env_id, render_mode="human")
    env2.reset(seed=0)
    assert pygame.display.get_surface() is not None
    assert not env2.unwrapped.user_closed_window
    env2.close()
    assert not pygame.display.get_init()


def test_a_window_survives_another_environment_closing_the_display():
    import pygame

    first = gym.make(ENV_ID, render_mode="human")
    first.reset(seed=0)
    second = gym.make(ENV_ID, render_mode="human")
    second.reset(seed=1)
    second.close()  # shuts the shared pygame display down
    assert not pygame.display.get_init()
    first.step(Action.DOWN)  # redraws, reopening the window
    assert pygame.display.get_surface() is not None
    assert not first.unwrapped.user_closed_window
    first.close()
    assert not pygame.display.get_init()


def test_rendering_survives_pygame_quit_called_elsewhere():
    import pygame

    env = gym.make(ENV_ID, render_mode="rgb_array")
    env.reset(seed=0)
    env.step(Action.DOWN)
    before = env.render()
    frozen_lake = gym.make("FrozenLake-v1", render_mode="rgb_array")
    frozen_lake.reset(seed=0)
    frozen_lake.render()
    frozen_lake.close()  # calls pygame.quit(), shutting the font module down
    assert not pygame.font.get_init()
    assert np.array_equal(env.render(), before)


@pytest.mark.parametrize("env_id", [ENV_ID, PHYSICS_ENV_ID])
def test_human_window_shows_the_same_picture_as_rgb_array(env_id):
    import pygame

    frames = {}
    for mode in ("human", "rgb_array"):
        env = gym.make(env_id, render_mode=mode)
        env.reset(options={"target": (2, 2)})
        env.step(Action.RIGHT)
        if mode == "human":
            window = pygame.display.get_surface()
            frames[mode] = pygame.surfarray.array3d(window).transpose(1, 0, 2)
        else:
            frames[mode] = env.render()
        env.close()
    assert np.array_equal(frames["human"], frames["rgb_array"])


def test_pygame_is_not_loaded_without_a_render_mode(run_python):
    script = (
        "import sys, gymnasium as gym, warehouse_phys\n"
        "for mode in (None, 'ansi'):\n"
        "    env = gym.make('warehouse-robot-v0', render_mode=mode)\n"
        "    env.reset(seed=0)\n"
        "    for a in range(4): env.step(a)\n"
        "    env.render() if mode else None\n"
        "    env.close()\n"
        "print('pygame' in sys.modules)\n"
    )
    assert run_python(script).strip() == "False"


# --------------------------------------------------------------------- sprites
@pytest.mark.parametrize("name", render_module.SPRITE_NAMES)
def test_every_sprite_is_found(name):
    path = render_module.sprite_path(name)
    assert path.is_file()
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_missing_sprite_gives_a_clear_error(tmp_path, monkeypatch):
    monkeypatch.setattr(render_module, "SPRITE_DIRS", (tmp_path,))
    with pytest.raises(FileNotFoundError, match=r"sprite 'robot\.png' not found.*make_sprites"):
        render_module.sprite_path("robot.png")
    env = WarehouseGridEnv(render_mode="rgb_array")
    env.reset(seed=0)
    with pytest.raises(FileNotFoundError, match="not found"):
        env.render()


def test_unreadable_sprite_gives_a_clear_error(tmp_path, monkeypatch):
    for name in render_module.SPRITE_NAMES:
        (tmp_path / name).write_bytes(b"not a png")
    monkeypatch.setattr(render_module, "SPRITE_DIRS", (tmp_path,))
    with pytest.raises(ValueError, match="could not be read"):
        WarehouseRenderer(2, 2).rgb_array((0, 0), (1, 1))


# ------------------------------------------------- fleet frames on small cells
def test_small_fleet_cells_draw_discs_keep_packages_visible_and_frame_the_delivered():
    px = 16  # under FLEET_SPRITE_MIN_PX: array drawing, no sprites
    renderer = WarehouseRenderer(3, 4, cell_px=px)
    robots = [(0.0, 0.0), (2.0, 3.0), (1.5, 1.0)]  # the third half-way between two cells
    packages = [(2, 3), (1, 1), (0, 0)]  # robot_0 stands on robot_2's package
    frame = renderer.fleet_rgb_array(robots, packages, delivered=[False, True, False])
    colours = render_module.MAP_ROBOT_COLOURS
    assert (frame[px // 2, px // 2] == colours[0]).all()  # robot_0's disc
    assert (frame[2 * px, 1 * px + px // 2] == colours[2]).all()  # robot_2 between cells
    assert (frame[0, 0] == colours[2]).all()  # robot_2's package framed round robot_0
    assert (frame[px + px // 2, px + px // 2] == render_module.MAP_PACKAGE).all()  # robot_1's
    assert (frame[px, px] == colours[1]).all()
    delivered_cell = frame[2 * px : 3 * px, 3 * px : 4 * px]
    assert (delivered_cell[0] == render_module.DELIVERED_FRAME).all()  # green all round
    assert (delivered_cell[:, -1] == render_module.DELIVERED_FRAME).all()
    assert (delivered_cell[px // 2, px // 2] == colours[1]).all()  # its colour inside
    assert (frame[0:px, 0:px] != render_module.DELIVERED_FRAME).any(axis=-1).all()
    renderer.close()
