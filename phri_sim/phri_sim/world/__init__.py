"""The simulated world (pure, no rclpy): MuJoCo robot, person, skins and their sensors."""
