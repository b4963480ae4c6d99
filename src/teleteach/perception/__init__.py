"""Perception: what the robot sees of the shop (products, gaps, tables) on teleteach/scene, and static_scene."""
