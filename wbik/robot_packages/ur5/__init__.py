"""Universal Robots UR5 (seed 002, example-robot-data) with the riveting tool: model and closed form."""
