"""PhantomX Pincher (seed 004): model (DH table, tool frame 'noa') and its closed form."""
