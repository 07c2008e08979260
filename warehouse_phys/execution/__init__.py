"""The execution floor: plans run in time, a move taking ticks, with delays; the executor
that says GO or STOP, its grid twin of robots between cells, and the windows it runs.
"""
