"""Bioloid application: servo map, foot sensors, gait, steps, walks, half steps, stairs, PlaCo walk."""
