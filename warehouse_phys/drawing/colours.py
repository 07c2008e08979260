"""The colours every picture of a floor shares: a fleet's robot colours, the frame round
a delivery and the pointer of a turning robot's heading, in the pygame renderer and the
array-drawn maps alike.
"""

from __future__ import annotations

DELIVERED_FRAME = (90, 200, 90)  # RGB: around the cell where the package was delivered
#: The pointer that shows a turning robot's heading in pictures.
HEADING_POINTER = (20, 20, 24)  # RGB

#: The colours of a fleet's robots and their packages, robot by robot (RGB).
#: A fleet's robot colours, robot ``i`` in ``FLEET_COLOURS[i % 8]`` [RGB]: Okabe and Ito's
#: palette, which colour-blind eyes tell apart (vermillion first: robot 0 is the one a
#: person drives in ``play``), with a violet for its black, which would pass for a shelf.
#: None is close to the floor's light tiles or the shelves' dark grey.
FLEET_COLOURS: tuple[tuple[int, int, int], ...] = (
    (213, 94, 0),
    (0, 114, 178),
    (0, 158, 115),
    (230, 159, 0),
    (204, 121, 167),
    (86, 180, 233),
    (240, 228, 66),
    (120, 94, 240),
)
