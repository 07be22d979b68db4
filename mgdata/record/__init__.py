"""Episode records and the LeRobot v3.0 dataset they are written to."""
