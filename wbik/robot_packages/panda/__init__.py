"""Franka Emika Panda 7-DOF arm (example-robot-data): a redundant reference chain."""
