"""Skill-based shared control (Mower, Moura, Vijayakumar, RSS 2021): models, estimation, optimisation, MPC loop."""
