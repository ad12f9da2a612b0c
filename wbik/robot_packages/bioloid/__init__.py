"""Bioloid Premium Type A humanoid (seed 003): model (18 servos, floating base, soles) and the
thesis's closed-form arm and leg IK."""
