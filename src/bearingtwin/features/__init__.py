"""Feature extraction: the paper's (SABO-tuned VMD, the optimal mode by envelope entropy, nine time-domain features)
and the envelope-order features (how the envelope's power is shared among the bearing's defect orders), which the
sim2real protocol trains on."""

NOT_AFFECTING_NUMBERS = ("n_jobs", "progress")
"""Feature settings that say how the extraction runs, not what it computes: left out of the feature cache's key
and of a run's config hash (changing them re-uses both)."""
