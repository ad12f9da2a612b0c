"""Applications built on the core: Golem-III grasp approach and thesis solvers, Pincher
teleoperation, Bioloid behaviours, UR5 riveting. Each registers its scenario kinds explicitly
(``wbik.scenarios.kinds.KIND_MODULES``)."""
