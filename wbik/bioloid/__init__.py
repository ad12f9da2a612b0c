"""Bioloid-specific layers on top of the generic model (wbik.models.bioloid): foot sensors (sensors.py)
and the servo map between joint angles and Dynamixel AX-12 positions (servo.py)."""
