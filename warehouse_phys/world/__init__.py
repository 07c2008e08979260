"""The world floor: the floor and its cells, layouts and maps, the traffic rule, the
turning robot and placement; the rules every twin follows. numpy and scipy only.
"""
