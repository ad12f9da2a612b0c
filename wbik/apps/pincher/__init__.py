"""PhantomX Pincher application: teleoperation moves and their scenario kind."""
