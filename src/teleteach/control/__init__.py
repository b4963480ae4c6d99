"""Stiffness ellipsoid maths, impedance law, joint trajectory controller, controller manager, validation."""
