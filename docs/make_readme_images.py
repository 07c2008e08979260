"""Render the pictures used by README.md into docs/: ``python docs/make_readme_images.py``."""

import os
import shutil
import tempfile
from pathlib import Path

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import gymnasium as gym
import numpy as np
import pygame

import warehouse_phys
from warehouse_phys import Action
from warehouse_phys.apps import sweep
from warehouse_phys.envs import fleet
from warehouse_phys.rl.fleet_learning import greedy_fleet_policy, train_fleet
from warehouse_phys.rl.greedy_policy import greedy_action
from warehouse_phys.rl.qlearning import QLearningConfig, train
from warehouse_phys.viz.figures import save_figure
from warehouse_phys.viz.plots import learning_curve_figure
from warehouse_phys.viz.recording import record_episode, record_fleet_episode

HERE = Path(__file__).resolve().parent
#: The fleet GIF's seed: one whose three packages the learned fleet all delivers.
FLEET_GIF_SEED = 8


def save(frame: np.ndarray, name: str) -> None:
    pygame.image.save(pygame.surfarray.make_surface(frame.transpose(1, 0, 2)), str(HERE / name))
    print(f"wrote {HERE / name}")


def main() -> None:
    env = gym.make(warehouse_phys.GRID_ENV_ID, render_mode="rgb_array")
    env.reset(options={"target": (3, 3)})
    for action in (Action.DOWN, Action.RIGHT, Action.DOWN, Action.RIGHT):
        env.step(action)
    save(env.render(), "grid_frame.png")
    env.close()

    # One move of the physics-backed twin: frames of the body between two cells.
    env = gym.make(warehouse_phys.PHYSICS_ENV_ID, render_mode="rgb_array", cell_px=40)
    env.reset(options={"target": (3, 3)})
    for action in (Action.DOWN, Action.RIGHT):
        env.step(action)
    env.step(Action.DOWN)
    frames = env.unwrapped.move_frames()
    picks = [frames[i] for i in (0, 3, 6, 9)] + [env.render()]
    gap = np.full((picks[0].shape[0], 6, 3), 255, dtype=np.uint8)
    strip = [part for frame in picks for part in (frame, gap)][:-1]
    save(np.concatenate(strip, axis=1), "phys_move_strip.png")
    env.close()

    # The layout presets side by side, each with a package waiting.
    frames = []
    for name, target in (("aisles", (4, 6)), ("depot", (5, 6)), ("maze", (2, 4))):
        env = gym.make(warehouse_phys.preset_ids(name)[0], render_mode="rgb_array", cell_px=32)
        env.reset(options={"target": target})
        frames.append(env.render())
        env.close()
    height = max(frame.shape[0] for frame in frames)
    padded = [
        np.pad(f, ((0, height - f.shape[0]), (0, 12), (0, 0)), constant_values=255) for f in frames
    ]
    save(np.concatenate(padded, axis=1)[:, :-12], "layouts.png")

    # What `python -m warehouse_phys.train` writes: the learning curve and the
    # greedy episode as a GIF, in each world (seed 0 puts the package on (3, 3)).
    env = gym.make(warehouse_phys.PHYSICS_ENV_ID)
    result = train(env, QLearningConfig(episodes=1000, seed=0))
    figure = learning_curve_figure(result, f"{warehouse_phys.PHYSICS_ENV_ID} 4x5, seed 0")
    save_figure(figure, HERE / "learning_curve.png")
    print(f"wrote {HERE / 'learning_curve.png'}")
    for env_id, name in (
        (warehouse_phys.PHYSICS_ENV_ID, "episode_phys.gif"),
        (warehouse_phys.GRID_ENV_ID, "episode_grid.gif"),
    ):
        env = gym.make(env_id, render_mode="rgb_array", cell_px=48)
        episode = record_episode(env, lambda obs: greedy_action(result.q, obs), seed=0)
        episode.animation().save(HERE / name)
        print(f"wrote {HERE / name}")
        env.close()

    # What `python -m warehouse_phys.sweep` draws (its trials run here, in this process,
    # through the same run_trial that Ray's workers call).
    argv = ["--env", "grid", "phys", "--layout", "default", "maze", "--seeds", "3"]
    argv += ["--episodes", "300", "--alpha", "0.5", "0.9"]
    trials = sweep.trials_from_args(sweep.build_parser().parse_args(argv))
    with tempfile.TemporaryDirectory() as folder:
        rows = [
            sweep._row(t, "done", sweep.run_trial(t.to_job(Path(folder), False))) for t in trials
        ]
        sweep.write_results(Path(folder), trials, rows)
        shutil.copy(Path(folder) / sweep.SUMMARY_PNG, HERE / "sweep_summary.png")
    print(f"wrote {HERE / 'sweep_summary.png'}")
    fleet_gif()
    warehouse_floor_png()


def warehouse_floor_png() -> None:
    """10,000 turning robots on the shipped 140 x 500 Kiva floor after 40 steps of PIBT."""
    from warehouse_phys.apps.simulate.lockstep import simulate
    from warehouse_phys.rl.fleet_planners import planner_policy

    env = fleet.parallel_env(
        num_robots=10_000, layout="kiva-140-500", moves="rotate", on_delivery="new_package"
    )
    run, frames = simulate(env, planner_policy("pibt"), steps=40, frames=2, cell_px=3)
    save(frames[-1], "warehouse_floor.png")
    print(f"wrote {HERE / 'warehouse_floor.png'} ({run.delivered} deliveries in 40 steps)")


def fleet_gif() -> None:
    """Three robots that learned with one shared table, driving in the physics world."""
    result = train_fleet(fleet.parallel_env(num_robots=3), QLearningConfig(episodes=3000, seed=0))
    env = fleet.parallel_env(num_robots=3, physics=True, render_mode="rgb_array", cell_px=48)
    animation, delivered = record_fleet_episode(
        env, greedy_fleet_policy(result.q), seed=FLEET_GIF_SEED, max_steps=20
    )
    animation.save(HERE / "fleet_phys.gif")
    print(f"wrote {HERE / 'fleet_phys.gif'} ({delivered} packages delivered)")


if __name__ == "__main__":
    main()
