"""From optimal cycles to a drive decision: power curves, annual energy, bands, drive sizing."""
