"""MuJoCo stand-in for the robot, its skins and the person; the paper's experiments as scenarios."""
