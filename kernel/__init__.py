"""The kernel every stage shares, at the bottom of drivebench: errors that name the bad
input, the file readers and atomic writers, units, output folders, the drive rating and
the recorded versions. It imports nothing of drivebench above it (docs/architecture.md)."""
