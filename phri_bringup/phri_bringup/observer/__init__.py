"""Watching a run: the observer node, rosbag2 MCAP recordings, link frames, Foxglove."""
