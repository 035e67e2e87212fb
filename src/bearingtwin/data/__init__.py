"""Data sources: simulated (the twin) and real (CWRU, HUST, generic files), windowing and splits."""
