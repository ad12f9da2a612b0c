"""Applications built on the core: Golem-III grasp approach and thesis solvers, Pincher
teleoperation, Bioloid behaviours, UR5 riveting. Their scenario kinds are registered in
:func:`wbik.catalog.scenario_kinds`."""
