"""Pure-Python conversions between phri's standard ROS messages and numpy;
shared parameter and test helpers."""
