"""Draw the project's sprites and write them as PNG files next to this script.

Run from anywhere: ``python sprites/make_sprites.py``. Every shape is drawn
at 4x the output size and scaled down smoothly, which antialiases the edges;
the output is 128 px square so it stays crisp at the renderer's default 64 px
cell. Nothing here is random, so the images are the same on every run.
"""

from __future__ import annotations

import os
from pathlib import Path

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame

OUTPUT_PX = 128  # [px] side of each written image
SUPERSAMPLE = 4  # drawing scale before the smooth downscale
S = OUTPUT_PX * SUPERSAMPLE  # [px] side of the drawing canvas
HERE = Path(__file__).resolve().parent


def px(fraction: float) -> int:
    """A length given as a fraction of the sprite's side, in canvas pixels."""
    return round(fraction * S)


def rect(x: float, y: float, w: float, h: float) -> pygame.Rect:
    """A rectangle given in fractions of the sprite's side."""
    return pygame.Rect(px(x), px(y), px(w), px(h))


def shadow(canvas: pygame.Surface, area: pygame.Rect, radius: int, alpha: int) -> None:
    """A soft dark shadow under ``area``, built from a few widening translucent layers."""
    layer = pygame.Surface((S, S), pygame.SRCALPHA)
    for grow in range(4, 0, -1):
        spread = grow * px(0.012)
        pygame.draw.rect(
            layer,
            (0, 0, 0, alpha // (grow + 1)),
            area.inflate(spread * 2, spread * 2),
            border_radius=radius + spread,
        )
    canvas.blit(layer, (0, 0))


def finish(canvas: pygame.Surface, name: str) -> None:
    image = pygame.transform.smoothscale(canvas, (OUTPUT_PX, OUTPUT_PX))
    pygame.image.save(image, str(HERE / name))
    print(f"wrote {HERE / name}")


def draw_floor() -> None:
    """Polished concrete tile with bevelled seams and a faint deterministic speckle."""
    canvas = pygame.Surface((S, S), pygame.SRCALPHA)
    canvas.fill((200, 202, 198, 255))
    # Speckle from a small linear congruential sequence: fixed, no RNG state.
    value = 12345
    for _ in range(700):
        value = (1103515245 * value + 12345) % 2**31
        x, y = value % S, (value // S) % S
        shade = 182 + (value >> 7) % 24
        pygame.draw.circle(
            canvas, (shade, shade + 2, shade - 2, 255), (x, y), px(0.006) + value % 3
        )
    seam = px(0.02)
    pygame.draw.rect(canvas, (225, 227, 223, 255), (0, 0, S, seam))  # light top edge
    pygame.draw.rect(canvas, (225, 227, 223, 255), (0, 0, seam, S))  # light left edge
    pygame.draw.rect(canvas, (150, 152, 148, 255), (0, S - seam, S, seam))  # dark bottom edge
    pygame.draw.rect(canvas, (150, 152, 148, 255), (S - seam, 0, seam, S))  # dark right edge
    # Painted floor-marking corners, as on a warehouse floor grid.
    mark, arm = (214, 178, 60, 255), px(0.12)
    for cx, cy, dx, dy in ((0, 0, 1, 1), (S, 0, -1, 1), (0, S, 1, -1), (S, S, -1, -1)):
        x0, y0 = cx + dx * px(0.06), cy + dy * px(0.06)
        pygame.draw.line(canvas, mark, (x0, y0), (x0 + dx * arm, y0), px(0.018))
        pygame.draw.line(canvas, mark, (x0, y0), (x0, y0 + dy * arm), px(0.018))
    finish(canvas, "floor.png")


def draw_package() -> None:
    """A cardboard box seen from above: flaps, packing tape and a shipping label."""
    canvas = pygame.Surface((S, S), pygame.SRCALPHA)
    box = rect(0.18, 0.18, 0.64, 0.64)
    shadow(canvas, box.move(px(0.03), px(0.04)), px(0.03), 150)
    pygame.draw.rect(canvas, (196, 146, 86, 255), box, border_radius=px(0.03))
    pygame.draw.rect(canvas, (120, 82, 40, 255), box, width=px(0.018), border_radius=px(0.03))
    # The seam between the two top flaps, then tape across it.
    pygame.draw.line(
        canvas, (150, 104, 54, 255), (box.left, box.centery), (box.right, box.centery), px(0.012)
    )
    tape = rect(0.445, 0.18, 0.11, 0.64)
    pygame.draw.rect(canvas, (226, 196, 138, 255), tape)
    pygame.draw.line(canvas, (176, 136, 80, 255), tape.topleft, tape.bottomleft, px(0.006))
    pygame.draw.line(canvas, (176, 136, 80, 255), tape.topright, tape.bottomright, px(0.006))
    # Shipping label with a barcode in the lower-right quarter.
    label = rect(0.58, 0.58, 0.19, 0.14)
    pygame.draw.rect(canvas, (246, 246, 240, 255), label, border_radius=px(0.01))
    for i, width in enumerate((2, 1, 3, 1, 2, 1, 1, 3, 2)):
        x = label.left + px(0.02) + i * px(0.017)
        pygame.draw.rect(
            canvas, (30, 30, 30, 255), (x, label.top + px(0.025), width * px(0.004), px(0.09))
        )
    pygame.draw.rect(canvas, (120, 82, 40, 255), box, width=px(0.018), border_radius=px(0.03))
    finish(canvas, "package.png")


def draw_robot() -> None:
    """A top-down warehouse robot: orange chassis, wheels, dark deck, lidar dome, front light."""
    canvas = pygame.Surface((S, S), pygame.SRCALPHA)
    body = rect(0.14, 0.12, 0.72, 0.76)
    shadow(canvas, body.move(px(0.025), px(0.035)), px(0.14), 170)
    # Wheels peeking out at the sides.
    for x in (0.09, 0.81):
        for y in (0.2, 0.62):
            pygame.draw.rect(
                canvas, (34, 36, 40, 255), rect(x, y, 0.10, 0.18), border_radius=px(0.03)
            )
    pygame.draw.rect(canvas, (244, 142, 32, 255), body, border_radius=px(0.14))
    pygame.draw.rect(canvas, (150, 78, 10, 255), body, width=px(0.02), border_radius=px(0.14))
    # Dark load deck and its bevel.
    deck = rect(0.24, 0.30, 0.52, 0.48)
    pygame.draw.rect(canvas, (58, 62, 70, 255), deck, border_radius=px(0.06))
    pygame.draw.rect(canvas, (92, 98, 108, 255), deck, width=px(0.014), border_radius=px(0.06))
    # Lidar dome on the deck.
    centre = (px(0.5), px(0.54))
    pygame.draw.circle(canvas, (24, 26, 30, 255), centre, px(0.12))
    pygame.draw.circle(canvas, (190, 198, 206, 255), centre, px(0.09))
    pygame.draw.circle(
        canvas, (120, 200, 255, 255), (centre[0] - px(0.025), centre[1] - px(0.025)), px(0.03)
    )
    # Front (top edge) light bar and two status LEDs.
    pygame.draw.rect(
        canvas, (60, 230, 170, 255), rect(0.34, 0.16, 0.32, 0.06), border_radius=px(0.03)
    )
    pygame.draw.circle(canvas, (255, 240, 120, 255), (px(0.24), px(0.22)), px(0.025))
    pygame.draw.circle(canvas, (255, 240, 120, 255), (px(0.76), px(0.22)), px(0.025))
    finish(canvas, "robot.png")


def draw_shelf() -> None:
    """A steel pallet rack seen from above: blue uprights and beams, slatted deck, two totes.

    No orange anywhere: the tests find the robot by its orange chassis.
    """
    canvas = pygame.Surface((S, S), pygame.SRCALPHA)
    frame = rect(0.04, 0.04, 0.92, 0.92)
    shadow(canvas, frame.move(px(0.02), px(0.03)), px(0.02), 160)
    pygame.draw.rect(canvas, (88, 94, 102, 255), frame, border_radius=px(0.02))  # deck
    for i in range(7):  # deck slats
        y = frame.top + px(0.07) + i * px(0.12)
        pygame.draw.rect(canvas, (112, 119, 128, 255), (frame.left, y, frame.width, px(0.07)))
    beam = (38, 84, 160, 255)
    pygame.draw.rect(canvas, beam, rect(0.04, 0.04, 0.92, 0.07))  # front beam
    pygame.draw.rect(canvas, beam, rect(0.04, 0.89, 0.92, 0.07))  # back beam
    for x in (0.04, 0.89):  # uprights at the corners
        for y in (0.04, 0.89):
            pygame.draw.rect(canvas, (24, 52, 108, 255), rect(x, y, 0.07, 0.07))
    # Two plastic totes and a lid seen from above.
    for x, y, colour in ((0.14, 0.17, (60, 130, 110, 255)), (0.52, 0.50, (70, 110, 170, 255))):
        tote = rect(x, y, 0.34, 0.32)
        shadow(canvas, tote.move(px(0.015), px(0.02)), px(0.02), 120)
        pygame.draw.rect(canvas, colour, tote, border_radius=px(0.02))
        dark = (*(max(0, v - 40) for v in colour[:3]), 255)
        pygame.draw.rect(canvas, dark, tote, width=px(0.016), border_radius=px(0.02))
        pygame.draw.rect(canvas, dark, tote.inflate(-px(0.14), -px(0.2)), border_radius=px(0.01))
    pygame.draw.rect(canvas, (20, 22, 26, 255), frame, width=px(0.012), border_radius=px(0.02))
    finish(canvas, "shelf.png")


def main() -> None:
    draw_floor()
    draw_package()
    draw_robot()
    draw_shelf()


if __name__ == "__main__":
    main()
