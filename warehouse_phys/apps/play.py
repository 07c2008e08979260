"""``python -m warehouse_phys.play``: drive the robot yourself with the arrow keys.

A window shows the warehouse and, under it, the step count, the reward of
the last step and the episode's return. Each arrow key is one action; in the
physics-backed environment (the default) the move plays as the body's real
motion, in the grid twin the robot jumps. When the robot reaches the package
or the time limit ends the episode, the next arrow key starts a new one.

Keys: arrows drive, ``R`` starts a new episode, ``Escape`` (or closing the
window) quits.

    python -m warehouse_phys.play
    python -m warehouse_phys.play --env grid --rows 6 --cols 8 --seed 3
    python -m warehouse_phys.play --layout maze
    python -m warehouse_phys.play --robots 4

With ``--robots N`` a fleet shares the floor: you drive ``robot_0`` (red, like
its package; space waits) and the others follow the PIBT planner
(:mod:`warehouse_phys.planners.pibt`), which moves them out of your way, under the
fleet's traffic rule.

The first episode is reset with ``--seed``, the next ones continue its random
stream, so a seed replays the same sequence of targets. Bad arguments end
with exit status 2 and a one-line message, before any window opens; a
machine with no display ends with exit status 1 and says so.
"""

from __future__ import annotations

from warehouse_phys._starting import command_interrupts

# python -m warehouse_phys.apps.<app> runs this module as __main__: Ctrl-C while it
# imports is the command's one line, as with the short name's.
with command_interrupts(__name__ == "__main__"):
    import argparse
    import sys
    from typing import Any

    import gymnasium as gym
    import numpy as np

    from warehouse_phys.apps.cli import (
        DEFAULT_ENV,
        ArgumentParser,
        Floor,
        UsageError,
        add_env_argument,
        add_floor_arguments,
        add_robots_argument,
        bounded_int,
        floor_from_args,
        warnings_in_one_line,
    )
    from warehouse_phys.apps.interrupts import interruption, stops_on_sigterm
    from warehouse_phys.drawing.display import NoDisplayError, check_display, import_pygame
    from warehouse_phys.drawing.render import (
        DEFAULT_CELL_PX,
        MAX_FRAME_PIXELS,
        MAX_FRAME_SIDE_PX,
        FrameTooLargeError,
        fit_text,
    )
    from warehouse_phys.envs import WarehousePhysicsEnv
    from warehouse_phys.envs.fleet import WarehouseFleetEnv
    from warehouse_phys.planners.pibt import PIBT
    from warehouse_phys.world.grid import Action
    from warehouse_phys.world.traffic import WAIT

PROG = "python -m warehouse_phys.play"
#: Pace of the window while waiting for a key [frames/s].
IDLE_FPS = 30

HUD_BACKGROUND = (24, 27, 31)  # RGB
HUD_TEXT = (235, 235, 235)  # RGB
HUD_DONE = (120, 220, 120)  # RGB: the line that says the episode is over
HUD_LINE_PX = 22  # [px] height of one line of text under the frame
HUD_LINES = 3
DRIVING_KEYS = "arrows drive   R new episode   Esc quits"
NEXT_EPISODE_KEYS = "arrows or R: next episode   Esc quits"
FLEET_KEYS = "arrows drive   space waits   R new episode   Esc quits"


class PlaySession:
    """One environment driven from the keyboard in a pygame window.

    The environment must render ``"rgb_array"`` frames: the session owns the
    window and its events, and plays the physics-backed environment's moves
    from :meth:`~warehouse_phys.envs.WarehousePhysicsEnv.move_frames`.

    Args:
        env: The environment, made with ``render_mode="rgb_array"``.
        seed: Seed of the first reset; later episodes continue its stream.
        title: The window's caption.
    """

    def __init__(self, env: gym.Env, *, seed: int | None = None, title: str = PROG) -> None:
        if env.render_mode != "rgb_array":
            raise ValueError(
                f"PlaySession needs an environment made with render_mode='rgb_array', "
                f"not {env.render_mode!r}"
            )
        self.env = env
        self._pg = pg = import_pygame()
        #: The arrow keys and the actions they stand for.
        self.action_keys = {
            pg.K_LEFT: Action.LEFT,
            pg.K_DOWN: Action.DOWN,
            pg.K_RIGHT: Action.RIGHT,
            pg.K_UP: Action.UP,
        }
        self._physics = isinstance(env.unwrapped, WarehousePhysicsEnv)
        self._fps = float(env.metadata["render_fps"])
        #: False once the user pressed Escape or closed the window.
        self.running = True
        #: Episodes started so far, the current one included.
        self.episodes = 0
        self.steps = 0
        self.last_reward = 0.0
        self.episode_return = 0.0
        self.terminated = self.truncated = False
        self.obs: np.ndarray | None = None
        self.info: dict[str, Any] = {}
        self._optimal_from_start = 0

        check_display()
        frame = self._new_episode(seed)
        height, width = frame.shape[:2]
        pg.display.init()
        check_display(pg)
        pg.font.init()
        pg.display.set_caption(title)
        self._window = pg.display.set_mode((width, height + HUD_LINES * HUD_LINE_PX))
        self._font = pg.font.Font(None, HUD_LINE_PX)
        self._clock = pg.time.Clock()
        self._frame = frame
        self._draw()

    @property
    def episode_over(self) -> bool:
        """Whether the current episode reached the target or its time limit."""
        return self.terminated or self.truncated

    def run(self) -> None:
        """Handle keys and redraw until the user quits; then close the window."""
        try:
            while self.running:
                for event in self._pg.event.get():
                    self.handle(event)
                    if not self.running:
                        break
                else:
                    self._clock.tick(IDLE_FPS)
        finally:
            self.close()

    def handle(self, event: Any) -> None:
        """React to one pygame event: quit, a new episode, or a move."""
        pg = self._pg
        if event.type == pg.QUIT or (event.type == pg.KEYDOWN and event.key == pg.K_ESCAPE):
            self.running = False
        elif event.type == pg.KEYDOWN and event.key == pg.K_r:
            self._frame = self._new_episode(None)
            self._draw()
        elif event.type == pg.KEYDOWN and event.key in self.action_keys:
            if self.episode_over:
                self._frame = self._new_episode(None)
                self._draw()
            else:
                self.step(self.action_keys[event.key])

    def step(self, action: Action) -> None:
        """Take ``action``, playing the motion in the window, then update the counters.

        While the motion plays, the text under it still shows the counters from
        before the move: the reward and "Delivered" appear when the robot arrives.
        """
        obs, reward, terminated, truncated, info = self.env.step(action)
        if self._physics:
            # The move in real time: every frame but the last, which is before the snap.
            for frame in self.env.unwrapped.move_frames()[:-1]:
                self._frame = frame
                self._draw()
                self._clock.tick(self._fps)
        self.obs, self.terminated, self.truncated, self.info = obs, terminated, truncated, info
        self.steps += 1
        self.last_reward = float(reward)
        self.episode_return += self.last_reward
        self._frame = self.env.render()
        self._draw()

    def close(self) -> None:
        """Close the environment and the window; safe to call twice."""
        self.running = False
        self.env.close()
        if self._pg.display.get_init():
            self._pg.display.quit()

    def hud_lines(self) -> list[str]:
        """The text under the frame: the counters, the episode's outcome, the keys."""
        counters = (
            f"step {self.steps}   reward {self.last_reward:g}   return {self.episode_return:g}"
        )
        if self.terminated:
            extra = self.steps - self._optimal_from_start
            verdict = "a shortest path!" if extra <= 0 else f"{extra} more than the shortest"
            return [counters, f"Delivered in {self.steps} steps: {verdict}", NEXT_EPISODE_KEYS]
        if self.truncated:
            return [counters, f"Time is up after {self.steps} steps", NEXT_EPISODE_KEYS]
        return [counters, f"episode {self.episodes}: drive to the package", DRIVING_KEYS]

    # ------------------------------------------------------------------ helpers
    def _new_episode(self, seed: int | None) -> np.ndarray:
        self.obs, self.info = self.env.reset(seed=seed)
        self._optimal_from_start = int(self.info["optimal_steps"])
        self.episodes += 1
        self.steps = 0
        self.last_reward = self.episode_return = 0.0
        self.terminated = self.truncated = False
        return self.env.render()

    def _draw(self) -> None:
        pg, window = self._pg, self._window
        pg.event.pump()  # keeps the window responsive during a move; keys stay queued
        surface = pg.surfarray.make_surface(np.ascontiguousarray(self._frame.transpose(1, 0, 2)))
        window.blit(surface, (0, 0))
        top = self._frame.shape[0]
        window.fill(HUD_BACKGROUND, (0, top, window.get_width(), HUD_LINES * HUD_LINE_PX))
        for i, line in enumerate(self.hud_lines()):
            colour = HUD_DONE if i == 1 and self.episode_over else HUD_TEXT
            text = fit_text(self._font.render(line, True, colour), window.get_width() - 12)
            window.blit(text, (6, top + i * HUD_LINE_PX + (HUD_LINE_PX - text.get_height()) // 2))
        pg.display.flip()


class FleetPlaySession(PlaySession):
    """A fleet in the window: the person drives ``robot_0``, the others follow the
    :class:`~warehouse_phys.planners.pibt.PIBT` planner, which plans the person's move first
    and pushes teammates out of its way, so ``robot_0`` is never stuck behind one.

    Arrows move ``robot_0`` (red, like its package), space makes it wait; every
    key is one joint step of the whole fleet under the traffic rule. Once
    ``robot_0`` has delivered, keys keep the others going until all have.

    Args:
        env: The fleet, made with ``render_mode="rgb_array"``.
        seed: Seed of the first reset; later episodes continue its stream.
        title: The window's caption.
    """

    def __init__(
        self, env: WarehouseFleetEnv, *, seed: int | None = None, title: str = PROG
    ) -> None:
        self.delivered = 0
        self.refused = False
        self._planner: PIBT | None = None
        super().__init__(env, seed=seed, title=title)
        self.action_keys[self._pg.K_SPACE] = WAIT
        self._physics = env.physics
        self._fps = 1 / env.physics.dt if env.physics else float(env.metadata["render_fps"])

    def step(self, action: int) -> None:
        """One joint step: ``robot_0`` takes ``action``, the others what the planner says."""
        env = self.env
        if self._planner is None or env.steps == 0:
            self._planner = PIBT(env.grid, distances=env.distances,
                                 corner_follows=env.corner_follows, seed=0)  # fmt: skip
        planned = self._planner.plan(
            env.robot_cells, env.package_cells, ~env.parked & env.on_floor, env.on_floor,
            requests={0: int(action)} if "robot_0" in env.agents else None,
        ).tolist()  # fmt: skip
        actions = {agent: planned[int(agent.rsplit("_", 1)[1])] for agent in env.agents}
        if "robot_0" in env.agents:
            actions["robot_0"] = int(action)
        observations, rewards, _, truncations, infos = env.step(actions)
        if self._physics:
            for frame in env.move_frames()[:-1]:  # the motion in real time
                self._frame = frame
                self._draw()
                self._clock.tick(self._fps)
        self.obs = {agent: observations[agent] for agent in env.agents}
        self.info = {agent: infos[agent] for agent in env.agents}
        self.refused = bool(infos.get("robot_0", {}).get("refused", False))
        self.steps += 1
        self.last_reward = float(rewards.get("robot_0", 0.0))
        self.episode_return += self.last_reward
        self.delivered += int(sum(rewards.values()))
        self.truncated = any(truncations.values())
        self.terminated = not env.agents and not self.truncated
        self._frame = env.render()
        self._draw()

    def hud_lines(self) -> list[str]:
        """The counters, what ``robot_0`` is doing, and the keys."""
        robots = self.env.num_robots
        counters = f"step {self.steps}   delivered {self.delivered}/{robots}"
        if self.terminated:
            return [counters, f"Every package delivered in {self.steps} steps", NEXT_EPISODE_KEYS]
        if self.truncated:
            return [counters, f"Time is up after {self.steps} steps", NEXT_EPISODE_KEYS]
        if "robot_0" not in self.env.agents:
            line = "your robot delivered: keys move the others on"
        elif self.refused:
            line = "your move was refused: another robot holds or takes that cell"
        else:
            line = f"episode {self.episodes}: drive the red robot to the red package"
        return [counters, line, FLEET_KEYS]

    def _new_episode(self, seed: int | None) -> np.ndarray:
        self.obs, self.info = self.env.reset(seed=seed)
        self.episodes += 1
        self.steps = 0
        self.delivered = 0
        self.refused = False
        self.last_reward = self.episode_return = 0.0
        self.terminated = self.truncated = False
        return self.env.render()


def build_parser() -> argparse.ArgumentParser:
    """The command line's argument parser."""
    parser = ArgumentParser(
        prog=PROG,
        description="Drive the warehouse robot with the arrow keys (R: new episode, Esc: quit).",
    )
    add_env_argument(parser, default=DEFAULT_ENV, note="")
    add_floor_arguments(parser)
    parser.add_argument(
        "--seed",
        type=bounded_int(0, "a non-negative integer seed"),
        help="seed of the first episode's target (default: a new one each run)",
    )
    add_robots_argument(
        parser,
        what="a fleet of this many robots: you drive robot_0 (red), the others follow the "
        "planner and make way",
    )
    return parser


@stops_on_sigterm
@warnings_in_one_line(PROG)
def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status (130 on Ctrl-C, 143 on SIGTERM: the
    window closes, nothing is written)."""
    try:
        args = build_parser().parse_args(argv)
        floor = floor_from_args(args)
    except UsageError as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 2
    try:
        env = make_env(floor, args.env, args.robots)
    except FrameTooLargeError as error:  # play draws cells of DEFAULT_CELL_PX pixels
        grid = floor.grid()
        print(
            f"{PROG}: error: a {grid.rows}x{grid.cols} floor in play's {DEFAULT_CELL_PX}-pixel "
            f"cells makes frames of {error.size[0]}x{error.size[1]} pixels, more than a window "
            f"can draw (at most {MAX_FRAME_SIDE_PX} a side and {MAX_FRAME_PIXELS:,} in all): "
            "play a smaller floor",
            file=sys.stderr,
        )
        return 2
    except ValueError as error:  # a floor too small for the fleet
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 2
    pg = import_pygame()
    try:
        if args.robots > 1:
            title = f"{PROG}: {args.robots} robots on {floor.env_id(args.env)}"
            session: PlaySession = FleetPlaySession(env, seed=args.seed, title=title)
        else:
            session = PlaySession(env, seed=args.seed, title=f"{PROG}: {env.spec.id}")
    except NoDisplayError as error:  # an SSH session, a container, a CI machine
        env.close()
        pg.display.quit()
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 1
    except pg.error as error:  # SDL could not open the window after all
        env.close()
        pg.display.quit()
        print(f"{PROG}: error: cannot open a window ({error})", file=sys.stderr)
        return 1
    except BaseException:
        env.close()
        raise
    try:
        session.run()
    except KeyboardInterrupt as interrupt:  # Ctrl-C, or SIGTERM as a Terminated
        session.close()
        return interruption(interrupt)[1]
    return 0


def make_env(floor: Floor, kind: str, robots: int) -> gym.Env | WarehouseFleetEnv:
    """The environment to play: the single robot's, or a fleet of ``robots``."""
    if robots > 1:
        return floor.make_fleet(kind, robots, render_mode="rgb_array")
    return floor.make(kind, render_mode="rgb_array")


if __name__ == "__main__":
    sys.exit(main())
