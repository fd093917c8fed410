"""Models of the system: aerodynamics, the kite DAE and the drive's speed, torque and power."""
