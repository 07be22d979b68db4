"""SO-101 leader arm (Feetech STS3215): calibration, readings and forward kinematics."""
