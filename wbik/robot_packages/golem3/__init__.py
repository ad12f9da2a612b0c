"""Golem-III service robot (seed 000): model (thesis DH, torso lift, two arms) and the arms' closed form."""
