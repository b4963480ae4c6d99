"""Robot skills: the predefined pick-and-place skills of the thesis (Appendix B.2) and stiffness-skill replay."""
