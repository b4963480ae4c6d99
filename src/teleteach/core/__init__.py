"""The words and maths every part speaks, importing no other part of teleteach.

The shop's scene and its perception message, frames and rotations, command validation, the skill file, a study's
phases, the GUI's tabs and parameters, the package's files and data directory (docs/architecture.md).
"""
