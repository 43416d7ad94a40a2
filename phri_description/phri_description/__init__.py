"""Robot description of the dual-arm mobile manipulator (mecanum base, two UR16e, three skin
patches): URDF and MuJoCo model generation."""
