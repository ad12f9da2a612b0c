"""Golem-III application: the straight grasp approach (golem3.md) and its scenario kind."""
