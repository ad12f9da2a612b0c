"""Bioloid-specific layers on top of the generic model (wbik.models.bioloid): foot sensors."""
