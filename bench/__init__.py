"""drivebench: winch-drive bench logs -> Parquet store (ingestion, store, synthetic campaigns)."""

__version__ = "0.1.0"
