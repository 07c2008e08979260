"""Figures and recordings of trained policies and of the physics: plots and GIFs of
episodes. Above the learners, below the apps.
"""
