"""The wiping task: a surface wiped under shared control with a taught stiffness."""
