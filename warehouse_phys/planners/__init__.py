"""The planners floor: PIBT and its variants (guidance, lanes, operations), the distance
maps and the compiled searches they rank moves by. Plans only; never moves a robot.
"""
