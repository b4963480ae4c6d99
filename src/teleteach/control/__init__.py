"""The arm, real or simulated: its model, its maths and its controllers.

The Panda's joints and kinematics, stiffness ellipsoid maths, impedance law, joint trajectory controller, controller
manager, and the real robot's stiffness bridge.
"""
