"""Learning demonstrated skills: geometry-aware DMPs for stiffness (thesis Appendix C) and classic DMPs for poses.

``spd`` holds the SPD-manifold maps, ``dmp`` the movement primitives, ``preprocess`` the alignment, resampling and
smoothing of recorded streams, ``skill`` learning and reproducing a whole skill file, ``bag`` reading a session bag,
``plot`` the Fig. C.1-like figure.
"""
