"""Learning and evaluation over the environments: tabular Q-learning and its table
files, the fleet learner, fleet policies and measures, Stable-Baselines3 glue.
"""
