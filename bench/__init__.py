"""drivebench: bench logs of a winch drive -> Parquet store (this package: CLI, ingestion, store)."""

__version__ = "0.1.0"
