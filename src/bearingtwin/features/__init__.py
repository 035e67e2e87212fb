"""Feature extraction: SABO-tuned VMD, the optimal mode by envelope entropy, nine time-domain features."""
