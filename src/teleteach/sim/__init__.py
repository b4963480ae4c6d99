"""pybullet world: the Panda on a mobile base in a supermarket, its kinematics, and the robot_sim node."""
