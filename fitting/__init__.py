"""drivebench stage package: fitting."""
