"""drivebench: winch-drive bench logs -> Parquet store (CLI, ingestion, store)."""

__version__ = "0.1.0"
