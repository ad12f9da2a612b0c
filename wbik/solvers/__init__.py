"""IK methods behind one interface: the solver template, the result and its shared check, one module per
method and the method registry."""
