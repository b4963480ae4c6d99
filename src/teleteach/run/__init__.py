"""The main job and in-process placement trials.

The thesis experiments run end to end, unattended (:mod:`teleteach.run.thesis`); placement trials on the simulation,
faster than real time (:mod:`teleteach.run.trials`).
"""
