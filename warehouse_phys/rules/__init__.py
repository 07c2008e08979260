"""The rules floor: the pure world model (grid, batched tables, layouts and maps,
the fleet's traffic rule, distance maps, the PIBT planner). numpy and scipy only:
no gymnasium, pymunk or pygame.
"""
