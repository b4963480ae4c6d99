"""Perception: static_scene, a belief of the shop from a scene file (the teleteach/scene format: core.observed)."""
