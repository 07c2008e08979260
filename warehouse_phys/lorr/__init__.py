"""The League of Robot Runners floor: the competition's instances, errands and schedulers,
an instance's congestion-free flow, and its output file.
"""
