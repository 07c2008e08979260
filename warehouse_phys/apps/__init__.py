"""The command lines (train, play, simulate, sweep) and what they share (argument
parsing, run folders of a training run). `python -m warehouse_phys.<app>` runs them.
"""
