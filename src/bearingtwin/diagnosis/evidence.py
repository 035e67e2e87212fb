"""Physics evidence beside a verdict: which defect frequency stands out in the record's envelope spectrum.

The classical diagnosis of a localized bearing fault, with no learning: band-pass the record
where the impacts ring, square its envelope, and look at the squared-envelope spectrum at the
repetition rates the geometry and the shaft speed predict (BPFI for the inner race, BPFO for
the outer race, 2 x BSF for a ball: a spalled ball strikes both races once per spin). Each
state's evidence is how far its first harmonics stand above the spectrum's local floor, in dB;
the state whose harmonic series stands highest is the evidence's state, and ``normal`` when
none stands out by ``threshold_db``.

A series, not a single line, is the witness: an unrelated line (supply, gear mesh) can sit
near one harmonic, rarely near three. Prominences are ratios of one spectrum's powers, so they
do not depend on the sensor's gain or unit. The spectrum is a Welch average over segments of
``segment_s`` seconds, which steadies the floor; a speed that drifts by up to ``tolerance``
(relative) keeps its line inside the search band.

The band is fixed by default, or chosen per record by the kurtogram (``band="kurtogram"``: where
the record is most impulsive). The settings (band as a fraction of the Nyquist rate, three harmonics, 6 dB) are fixed a priori
for any rig, not tuned to a data set: the band is the one the envelope-order features use,
6 dB is a line four times the floor's power.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import scipy.fft
import scipy.signal

from bearingtwin.checks import is_finite_number, non_negative_number, positive_number, whole_number
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.signal.kurtogram import kurtogram

STATE_RATES = {"inner": "bpfi", "ball": "bsf2", "outer": "bpfo"}
"""Fault state -> the repetition rate its impacts leave in the envelope."""
BANDS = ("fixed", "kurtogram")
MIN_SEGMENT_SAMPLES = 16
"""Fewest samples of a Welch segment: a shorter ``segment_s`` would be lengthened to this, not read as asked."""


@dataclass
class PhysicsEvidence:
    """What the envelope spectrum of one record says.

    Attributes:
        prominence_db: state -> mean prominence (dB over the local floor) of its first harmonics.
        evidence_state: the state whose lines stand highest; ``normal`` when none reaches ``threshold_db``;
            None when no state's series can be read (see ``unreadable``): the physics has no answer.
        lines_hz: state -> the harmonic frequencies read, Hz.
        unreadable: state -> why its series cannot be read on this bearing at this resolution (each
            of its harmonics on a shaft harmonic, which every machine's envelope carries): such a
            state has no prominence and is never the evidence's.
        band_hz: the band-pass the envelope was taken from, Hz.
        threshold_db: the prominence a series needs to count.
        freqs_hz, spectrum: the squared-envelope spectrum (for figures; not serialized by :meth:`as_dict`).
    """

    prominence_db: dict[str, float]
    evidence_state: str | None
    lines_hz: dict[str, list[float]]
    band_hz: tuple[float, float]
    threshold_db: float
    freqs_hz: np.ndarray
    spectrum: np.ndarray
    unreadable: dict[str, str]

    def decisive_state(self, threshold_db: float, margin_db: float) -> str | None:
        """The fault state whose series leaves no doubt: at least ``threshold_db`` over its floor and at least
        ``margin_db`` above every other readable state's series (:attr:`unreadable` ones have none); None when
        no series does."""
        ranked = sorted(self.prominence_db.items(), key=lambda item: item[1], reverse=True)
        if not ranked or ranked[0][1] < threshold_db:
            return None
        if len(ranked) > 1 and ranked[0][1] - ranked[1][1] < margin_db:
            return None
        return ranked[0][0]

    def as_dict(self) -> dict:
        result = asdict(self)
        for name in ("freqs_hz", "spectrum"):
            result.pop(name)
        result["band_hz"] = list(self.band_hz)
        return result


def squared_envelope_spectrum(signal, fs_hz: float, band_hz: tuple[float, float], segment_s: float = 1.0,
                              filter_order: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Welch power spectrum of the squared envelope of ``signal`` band-passed to ``band_hz``.

    Args:
        signal: (..., n) samples, any unit.
        fs_hz: sampling rate, Hz.
        band_hz: (low, high) band-pass edges, Hz (Butterworth, forward and backward).
        segment_s: Welch segment length, s (resolution 1 / segment_s Hz; shortened to the record).

    Returns:
        freqs_hz: (m,) Hz; power: (..., m) in unit^4/Hz.
    """
    signal = np.asarray(signal, dtype=np.float64)
    low, high = (float(v) for v in band_hz)
    if not 0.0 < low < high < fs_hz / 2.0:
        raise BearingTwinError(f"band_hz={list(band_hz)}: need 0 < low < high < fs/2 = {fs_hz / 2:g} Hz")
    sos = scipy.signal.butter(filter_order, (low, high), btype="bandpass", fs=fs_hz, output="sos")
    in_band = scipy.signal.sosfiltfilt(sos, signal, axis=-1)
    # A record's length is often a slow FFT size (CWRU 131: 43 x 2847): pad the Hilbert transform's FFT.
    n = signal.shape[-1]
    squared_envelope = np.abs(scipy.signal.hilbert(in_band, N=scipy.fft.next_fast_len(n), axis=-1)[..., :n]) ** 2
    nperseg = min(signal.shape[-1], max(MIN_SEGMENT_SAMPLES, int(round(segment_s * fs_hz))))
    return scipy.signal.welch(squared_envelope, fs=fs_hz, nperseg=nperseg, detrend="constant", axis=-1)


def line_prominence_db(freqs_hz: np.ndarray, power: np.ndarray, line_hz: float, half_width_hz: float,
                       floor_width_hz: float) -> float:
    """Peak power within ``line_hz +- half_width_hz`` over the median power of the flanks beyond it, dB."""
    distance = np.abs(freqs_hz - line_hz)
    in_line = distance <= half_width_hz
    flanks = ~in_line & (distance <= half_width_hz + floor_width_hz)
    if not in_line.any() or not flanks.any():
        raise BearingTwinError(f"{line_hz:.1f} Hz lies outside the envelope spectrum (0-{freqs_hz[-1]:.0f} Hz)")
    floor = np.median(power[flanks])
    return float(10.0 * np.log10(max(power[in_line].max(), 1e-300) / max(floor, 1e-300)))


def evidence_settings(settings: dict) -> dict:
    """The ``evidence`` settings of ``conf/diagnose.yaml`` checked once, before any record is read (a bad
    value would otherwise fail every record alike): the keyword arguments of :func:`physics_evidence`."""
    band, edges, tolerance, threshold_db = (settings[key] for key in ("band", "band_nyquist", "tolerance", "threshold_db"))
    if band not in BANDS:
        raise BearingTwinError(f"evidence.band={band!r}: choose one of {', '.join(BANDS)}")
    # The band-pass needs both edges inside (0, Nyquist), in order.
    if not (isinstance(edges, (list, tuple)) and len(edges) == 2 and all(map(is_finite_number, edges))
            and 0 < edges[0] < edges[1] < 1):
        raise BearingTwinError(f"evidence.band_nyquist must be [low, high], fractions of the Nyquist rate with "
                               f"0 < low < high < 1, got {edges!r}")
    # A search band half a line wide or wider would reach from half the line to 1.5 times it, over its neighbours.
    if not (is_finite_number(tolerance) and 0 < tolerance < 0.5):
        raise BearingTwinError(f"evidence.tolerance must be a relative half width above 0 and below 0.5, got {tolerance!r}")
    return {"band": band, "band_nyquist": [float(edge) for edge in edges],
            "harmonics": whole_number("evidence.harmonics", settings["harmonics"]),
            "segment_s": positive_number(settings["segment_s"], "evidence.segment_s", "seconds"),
            "tolerance": float(tolerance),
            # Prominence is over the local floor: a series below it (a negative threshold) is no evidence of anything.
            "threshold_db": non_negative_number("evidence.threshold_db", threshold_db, "a non-negative number of dB")}


def check_segment(segment_s: float, fs_hz: float) -> None:
    """Refuse a Welch segment of fewer than :data:`MIN_SEGMENT_SAMPLES` at the rate records are read at."""
    if segment_s * fs_hz < MIN_SEGMENT_SAMPLES:
        raise BearingTwinError(f"evidence.segment_s={segment_s:g} holds {segment_s * fs_hz:.3g} samples at the model's "
                               f"{fs_hz:g} Hz; give at least {MIN_SEGMENT_SAMPLES / fs_hz:.3g} s "
                               f"({MIN_SEGMENT_SAMPLES} samples)")


BAND_NYQUIST = (0.25, 0.9)
HARMONICS = 3
SEGMENT_S = 1.0
TOLERANCE = 0.01
THRESHOLD_DB = 6.0
"""The baseline's fixed settings (module docstring): :func:`physics_evidence`'s defaults, and what
:class:`PhysicsFirst` reads every window with."""


def fixed_band_hz(fs_hz: float, band_nyquist=BAND_NYQUIST) -> tuple[float, float]:
    """The band-pass edges, Hz, of ``band_nyquist`` (fractions of the Nyquist rate) at ``fs_hz``."""
    return tuple(float(v) * fs_hz / 2.0 for v in band_nyquist)


def physics_evidence(signal, fs_hz: float, rpm: float, bearing: dict, *, band: str = "fixed",
                     band_nyquist=BAND_NYQUIST, harmonics: int = HARMONICS, segment_s: float = SEGMENT_S,
                     tolerance: float = TOLERANCE, threshold_db: float = THRESHOLD_DB) -> PhysicsEvidence:
    """The envelope spectrum of one record read at each fault state's defect-frequency harmonics.

    The settings are taken as given: :func:`evidence_settings` checks a user's.

    Args:
        signal: 1-D record, any unit.
        fs_hz: its sampling rate; rpm: its shaft speed, rev/min.
        bearing: the bearing config (geometry -> defect frequencies).
        band: ``fixed`` (``band_nyquist``) or ``kurtogram``: the record's most impulsive band above
            a tenth of Nyquist (:func:`bearingtwin.signal.kurtogram.kurtogram`).
        band_nyquist: band-pass edges as fractions of the Nyquist rate, for ``band="fixed"``.
        harmonics: harmonics of each rate that form its series.
        segment_s: Welch segment length, s.
        tolerance: relative half width of each line's search band (speed drift, slip), at least one bin.
        threshold_db: prominence a series needs for its state to be the evidence's.
    """
    if not (np.isfinite(rpm) and rpm > 0):
        raise BearingTwinError(f"rpm must be a positive shaft speed, got {rpm}")
    frequencies = BearingGeometry.from_config(bearing).defect_frequencies(rpm)
    if band == "kurtogram":
        # Above the shaft harmonics and electrical lines, and wide enough to carry the fastest
        # defect rate's modulation sidebands (a band narrower than 2 x BPFI cannot show BPFI).
        widest_rate = max(frequencies["bpfi"], frequencies["bpfo"], 2.0 * frequencies["bsf"])
        levels = [n for n in (16, 32, 64, 128, 256) if fs_hz / n >= 2.0 * widest_rate] or [16]
        band_hz = kurtogram(np.asarray(signal, dtype=np.float64), fs_hz, nperseg=levels, min_hz=0.05 * fs_hz).band_hz
    else:
        band_hz = fixed_band_hz(fs_hz, band_nyquist)
    freqs_hz, power = squared_envelope_spectrum(signal, fs_hz, band_hz, segment_s)
    return read_envelope_spectrum(freqs_hz, power, frequencies, band_hz=band_hz, harmonics=harmonics,
                                  tolerance=tolerance, threshold_db=threshold_db)


def read_envelope_spectrum(freqs_hz: np.ndarray, power: np.ndarray, frequencies: dict, *, band_hz: tuple[float, float],
                           harmonics: int, tolerance: float, threshold_db: float) -> PhysicsEvidence:
    """:func:`physics_evidence`'s reading of one squared-envelope spectrum (``freqs_hz``, ``power``) at the defect
    ``frequencies`` (Hz, :meth:`BearingGeometry.defect_frequencies`) of the record it came from."""
    rates = {"bpfi": frequencies["bpfi"], "bpfo": frequencies["bpfo"], "bsf2": 2.0 * frequencies["bsf"]}
    resolution = freqs_hz[1] - freqs_hz[0]
    shaft_hz = frequencies["shaft"]
    all_lines = {state: [h * rates[rate] for h in range(1, harmonics + 1)] for state, rate in STATE_RATES.items()}
    prominence, lines, unreadable = {}, {}, {}
    for state, candidates in all_lines.items():
        others = [line for other, series in all_lines.items() if other != state for line in series]
        half_widths = [max(tolerance * line, resolution) for line in candidates]
        # A harmonic that coincides with a shaft harmonic or another state's line cannot tell the
        # states apart (on the CWRU 6205, 3 x BPFO lies 0.7 % from 2 x BPFI, 3 x 2BSF 1 % from 14 x
        # shaft): the series is read at the unambiguous harmonics, and at the fundamental unless a
        # shaft harmonic lies inside its search band (another state's line is there only when that
        # fault is; a shaft harmonic always is: on the CWRU fan end's 6203, 2 x BSF is 3.99 orders).
        lines[state] = [line for h, (line, half) in enumerate(zip(candidates, half_widths))
                        if (h == 0 and not _near_shaft_harmonic(line, shaft_hz, half))
                        or not _ambiguous(line, others, shaft_hz, 2.0 * half)]
        if not lines[state]:
            order = candidates[0] / shaft_hz
            reach = (f"its search band (+-{half_widths[0]:.1f} Hz: {resolution:.2g} Hz bins)" if half_widths[0] == resolution
                     else f"its search band (+-{half_widths[0]:.1f} Hz)")
            unreadable[state] = (f"its {STATE_RATES[state].upper().replace('BSF2', '2 x BSF')} fundamental, "
                                 f"{order:.3f} shaft orders, has {round(order)} x shaft within {reach}, and its other "
                                 "harmonics lie on shaft harmonics or on another state's lines")
            continue
        # Flanks half a shaft order wide: inside them no other line of the same fault
        # (an inner-race fault's shaft sidebands sit a whole order away).
        values = [line_prominence_db(freqs_hz, power, line, max(tolerance * line, resolution),
                                     max(0.5 * shaft_hz, 3 * resolution)) for line in lines[state]]
        prominence[state] = float(np.mean(values))
    strongest = max(prominence, key=prominence.get, default=None)
    state = None if strongest is None else strongest if prominence[strongest] >= threshold_db else "normal"
    lines = {name: series for name, series in lines.items() if series}
    return PhysicsEvidence(prominence, state, lines, band_hz, float(threshold_db), freqs_hz, power, unreadable)


def _near_shaft_harmonic(line_hz: float, shaft_hz: float, separation_hz: float) -> bool:
    return abs(line_hz - round(line_hz / shaft_hz) * shaft_hz) < separation_hz


def _ambiguous(line_hz: float, other_lines_hz: list[float], shaft_hz: float, separation_hz: float) -> bool:
    """Whether a line lies within ``separation_hz`` of a shaft harmonic or of another state's line."""
    return _near_shaft_harmonic(line_hz, shaft_hz, separation_hz) or any(
        abs(line_hz - other) < separation_hz for other in other_lines_hz)


@dataclass(frozen=True)
class PhysicsFirst:
    """Let the envelope spectrum decide a window where it leaves no doubt, the classifier elsewhere.

    A classifier learns how a fault's lines stand against the rest of one path's content; through
    another path (another accelerometer, another rig) the same series may stand as high while the
    rest differs, and the classifier may then send it to a class that has no series of its own. No
    diagnostician overrules a series standing ``threshold_db`` over its floor and ``margin_db`` above
    every other state's: such a window is called by :func:`physics_evidence` (its defaults, the
    physics baseline's reading), and the classifier decides the rest: ball faults, faint or masked
    faults, healthy bearings (results/sim2real_protocol.md, version 9).
    """

    threshold_db: float = 20.0
    margin_db: float = 10.0

    def __post_init__(self):
        for name in ("threshold_db", "margin_db"):
            non_negative_number(f"physics_first.{name}", getattr(self, name), "a non-negative number of dB")

    def states(self, windows, fs_hz: float, rpm, bearing: dict) -> list[str | None]:
        """Each window's decisive fault state (:meth:`PhysicsEvidence.decisive_state`), None where there is none.

        Args:
            windows: (n, samples) raw windows, any unit; fs_hz: their sampling rate.
            rpm: shaft speed, rev/min, one for all windows or one per window.
            bearing: the config of the bearing the windows were recorded on.
        """
        windows = np.asarray(windows, dtype=np.float64)
        if windows.ndim != 2:
            raise BearingTwinError(f"windows must have shape (n, samples), got {windows.shape}")
        rpms = np.asarray(rpm, dtype=np.float64).reshape(-1)
        if rpms.size not in (1, len(windows)):
            raise BearingTwinError(f"rpm: one shaft speed, or one per window ({len(windows)}), got {rpms.size}")
        bad = np.flatnonzero(~(np.isfinite(rpms) & (rpms > 0)))
        if bad.size:
            raise BearingTwinError(f"rpm must be a positive shaft speed, got {rpms[bad[0]]:g}"
                                   + (f" for window {bad[0]}" if rpms.size > 1 else ""))
        # physics_evidence's reading with the baseline's settings, the windows' spectra in one batch (the same
        # numbers as window by window: every transform runs along the last axis).
        band_hz = fixed_band_hz(fs_hz)
        freqs_hz, power = squared_envelope_spectrum(windows, fs_hz, band_hz, SEGMENT_S)
        geometry = BearingGeometry.from_config(bearing)
        return [read_envelope_spectrum(freqs_hz, row, geometry.defect_frequencies(float(speed)), band_hz=band_hz,
                                       harmonics=HARMONICS, tolerance=TOLERANCE, threshold_db=THRESHOLD_DB)
                .decisive_state(self.threshold_db, self.margin_db)
                for row, speed in zip(power, np.broadcast_to(rpms, (len(windows),)))]
