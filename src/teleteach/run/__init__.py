"""The main job: the thesis experiments run end to end, unattended (see :mod:`teleteach.run.thesis`)."""
