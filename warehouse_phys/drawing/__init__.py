"""Drawing: frames of a floor (pygame sprites, array-drawn maps, text) and GIFs.
Knows the rules, never an environment.
"""
