"""Signal processing in the style of scipy.signal: arrays in, arrays out, batched along the leading axis."""

from bearingtwin.signal.envelope import envelope, envelope_spectrum, peak_near

__all__ = ["envelope", "envelope_spectrum", "peak_near"]
