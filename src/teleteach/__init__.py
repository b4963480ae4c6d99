"""teleteach: teaching robots high- and low-level skills through teleoperation."""
