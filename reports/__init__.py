"""drivebench stage package: reports."""
