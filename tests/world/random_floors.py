"""Small random floors for the property tests of the planners and the executor."""


def shelf_layout(rows: int, cols: int, shelf_bits: int) -> list[str]:
    """A ``rows`` x ``cols`` layout with a shelf where bit ``r * 7 + c`` of ``shelf_bits``
    is set (except on every third diagonal, which keeps most floors connected) and the
    start in the top-left corner."""
    cells = [["#" if (shelf_bits >> (r * 7 + c)) & 1 and (r + c) % 3 else "."
              for c in range(cols)] for r in range(rows)]  # fmt: skip
    cells[0][0] = "S"
    return ["".join(row) for row in cells]
