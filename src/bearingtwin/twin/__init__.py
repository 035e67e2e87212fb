"""The twin held against a measurement: comparison views, calibration and effect ranking."""
