"""phri_hardware: real robot bridges (UR16e over RTDE, mecanum base guard)."""
