"""Serial skin boards to calibrated taxel arrays at 500 Hz, with a simulated board."""
