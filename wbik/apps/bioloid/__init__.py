"""Bioloid application: servo map, foot sensors, gait, the thesis step and walks, half steps,
stairs, PlaCo walk, and their scenario kinds (robot model: wbik.robot_packages.bioloid.model)."""
