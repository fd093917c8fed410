"""The system: kite, aerodynamics, tether, winch, drive limits, wind and bounds (data only)."""
