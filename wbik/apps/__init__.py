"""Applications on the core: Golem-III, Pincher, Bioloid, UR5 riveting (kinds in wbik.catalog)."""
