"""Feature extraction: SABO-tuned VMD, the optimal mode by envelope entropy, nine time-domain features."""

NOT_AFFECTING_NUMBERS = ("n_jobs", "progress")
"""Feature settings that say how the extraction runs, not what it computes: left out of the feature cache's key
and of a run's config hash (changing them re-uses both)."""
