"""PhantomX Pincher application: teleoperation moves (jog, plane line, automatic cycle) and
their scenario kind."""
