"""Visualisation for RViz: the commanded stiffness ellipsoid as a Marker at the end effector (thesis A.2.3)."""
