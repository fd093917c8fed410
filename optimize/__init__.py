"""drivebench stage package: optimize."""
