"""Signal processing in the style of scipy.signal: arrays in, arrays out, batched along the leading axis."""
