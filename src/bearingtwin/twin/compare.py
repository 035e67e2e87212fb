"""How far the twin is from a measurement, view by view, and where it fails.

A twin in m/s^2 and a measurement in g or volts are only comparable up to a sensor
gain, and two records of a random process only up to their realization. So every
view compares *statistics* that average over the record (Welch band levels,
segment-averaged envelope spectra, medians over windows), in dB, after one sensor
gain fitted in closed form: the gain that makes the twin's band levels agree with the
measurement's in the least-squares sense (the mean dB difference). Each view's error
is an RMS of dB differences, hence scale-free and exactly 0 when the twin is the
measurement times any gain; the overall discrepancy is the weighted mean of the views,
and each view's share of it says where the twin fails.

Another rig's transfer path differs from the twin's smoothly across the spectrum; the views
are built so such a difference does not outvote the specific signatures that tell effects
apart: the psd view removes a smooth trend in log frequency along with the gain
(``psd_detrend_order``), and the lines view looks only at narrow lines.

Views:
    psd: Welch power per log-spaced frequency band, gain and smooth trend removed -- where in
        frequency energy is concentrated differently (resonances, a noise floor).
    lines: prominence of narrow lines above the local spectrum level at low frequency --
        shaft harmonics, half orders, supply lines, tones; a faulty bearing's own lines (its defect's
        and their sidebands, and its balls' passing) are left to the envelope and harmonics views.
    envelope: segment-averaged envelope spectrum relative to its median, bin by bin up to
        past the last harmonic -- the paper's Figure 10 as a number.
    harmonics: prominence of the defect frequency's harmonics and sidebands above the
        envelope floor, and their widths (twice the RMS spread of their power) -- sharp lines versus smeared ones.
    statistics: medians over windows of the scale-free time-domain features (kurtosis and
        the crest, shape, impulse and margin factors) -- impulsiveness, saturation, bursts.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from functools import cached_property
from pathlib import Path

import numpy as np
from scipy import signal as sps
from scipy.ndimage import percentile_filter

from bearingtwin.checks import is_finite_number, positive_number, whole_number
from bearingtwin.data.recording import Recording
from bearingtwin.data.windows import cut_windows
from bearingtwin.errors import BearingTwinError
from bearingtwin.features.time_domain import FEATURE_NAMES, time_domain_features
from bearingtwin.physics.geometry import BearingGeometry, check_fault
from bearingtwin.signal.envelope import envelope_spectrum, peak_near
from bearingtwin.signal.sampling_rate import MAINS_HZ
from bearingtwin.signal.welch import WelchPSD

VIEWS = ("psd", "lines", "envelope", "harmonics", "statistics")

# dB per decade of ratio: power-like features take 10 log10, amplitude-like 20 log10.
_FEATURE_DB_PER_DECADE = {"kurtosis": 10.0}
# The statistics view leaves out the features that carry the signal's level (and the signed mean):
# the level is the psd view's, and a gain read off band levels is no estimate of the RMS ratio
# when a band is nearly silent in the twin, so "level after the gain" would count one misfit twice.
_LEVEL_FEATURES = ("mean", "variance", "peak_to_peak", "rms")
STATISTICS_FEATURES = tuple(name for name in FEATURE_NAMES if name not in _LEVEL_FEATURES)
_REFERENCE_NAME = {"inner": "BPFI", "outer": "BPFO", "ball": "BSF", "normal": "shaft"}


@dataclass(frozen=True)
class CompareSettings:
    """Resolution of the views; mirrors the ``compare:`` block of ``conf/twin.yaml``.

    Attributes:
        welch_segment_s: Welch segment length in s (sets the PSD resolution, 1 / segment).
        band_min_hz: lower edge of the lowest PSD band; bands are log-spaced up to fs / 2.
        n_bands: number of PSD bands.
        dynamic_range_db: levels more than this below a spectrum's maximum are clipped there,
            as a real sensor's noise floor would, so numerically silent bands do not dominate.
        envelope_segment_s: envelope spectra are averaged over segments of this length (50 %
            overlap); twin and measurement share it so line widths are comparable.
        envelope_highpass_hz: the envelope is taken above this frequency (4th-order Butterworth,
            zero phase), as in classical envelope analysis: impacts are broadband, while strong
            low-frequency lines (supply, shaft) would otherwise beat in the envelope.
        envelope_dynamic_range_db: envelope-spectrum levels are floored this far below the
            spectrum's highest line, so the leakage floor of a perfectly periodic twin (60 dB
            and more down) and a slightly jittered one do not count as different.
        psd_detrend_order: order of the polynomial in log frequency removed from the band-level
            difference (0: the gain only; 1: also a tilt, a transfer path rising or falling
            across the spectrum).
        lines_segment_s: segment length of the averaged periodogram the lines view reads
            (resolution 1 / segment: half orders of a 30 Hz shaft need 0.5 s or longer).
        lines_max_hz: highest frequency the lines view examines.
        line_threshold_db: a bin counts as a line when it stands this far above the local level
            of its neighbourhood (the averaged periodogram's own scatter stays below, but for a
            rare bin of a record of few segments: white noise against white noise, 1 s records,
            a lines error of 1.0 dB on average, 0.02 dB over the median of 21 bins; 2 s records, none).
        line_level_percentile: the local level is this percentile of the neighbourhood's bins (50:
            the median). Low, so that a dense comb of lines (looseness: half orders and many
            harmonics), whose skirts fill more than half of a neighbourhood, does not lift the level
            it is measured from (the median reads a 37 dB line of such a comb as 20 dB). The
            price: where the spectrum rises steeply across a neighbourhood (20 dB from 10 to 80 Hz
            for a noiseless impact train), its upper bins stand a few dB over the percentile.
        line_level_bins: the neighbourhood's width in bins (odd).
        n_harmonics: harmonics of the defect frequency examined.
        smooth_hz: moving-average width of the dB envelope spectrum in the envelope view.
        stats_window_s: window length for the time-domain statistics.
        weights: weight of each view in the overall discrepancy, relative (scaled to a mean of 1 over the views).
    """

    welch_segment_s: float = 0.1
    band_min_hz: float = 50.0
    n_bands: int = 12
    dynamic_range_db: float = 80.0
    envelope_segment_s: float = 0.5
    envelope_highpass_hz: float = 500.0
    envelope_dynamic_range_db: float = 40.0
    psd_detrend_order: int = 1
    lines_segment_s: float = 0.5
    lines_max_hz: float = 1000.0
    line_threshold_db: float = 8.0
    line_level_percentile: float = 20.0
    line_level_bins: int = 41
    n_harmonics: int = 5
    smooth_hz: float = 10.0
    stats_window_s: float = 0.1
    weights: dict = field(default_factory=lambda: {view: 1.0 for view in VIEWS})

    def __post_init__(self) -> None:
        # Frozen: the checked values are set as the numbers they were read as (ints, floats).
        for name, unit in _POSITIVE_SETTINGS.items():
            object.__setattr__(self, name, positive_number(getattr(self, name), f"compare.{name}", unit))
        if not (is_finite_number(self.smooth_hz) and self.smooth_hz >= 0):
            raise BearingTwinError(f"compare.smooth_hz must be a non-negative number of Hz (0: no smoothing), "
                                   f"got {self.smooth_hz!r}")
        object.__setattr__(self, "n_harmonics", whole_number("compare.n_harmonics", self.n_harmonics))
        if not (is_finite_number(self.line_level_percentile) and 0 < self.line_level_percentile <= 100):
            raise BearingTwinError(f"compare.line_level_percentile must lie in (0, 100], got {self.line_level_percentile!r}")
        bins = whole_number("compare.line_level_bins", self.line_level_bins, minimum=3)
        if bins % 2 == 0:
            raise BearingTwinError(f"compare.line_level_bins must be odd (a bin in the middle of its neighbourhood), got {bins}")
        object.__setattr__(self, "line_level_bins", bins)
        # The band levels lose a polynomial of psd_detrend_order: at least one value must be left beyond it.
        order = whole_number("compare.psd_detrend_order", self.psd_detrend_order, minimum=0)
        n_bands = whole_number("compare.n_bands", self.n_bands)
        if n_bands < order + 2:
            raise BearingTwinError(f"compare.n_bands={n_bands} leaves no band level beyond the polynomial of order "
                                   f"compare.psd_detrend_order={order}: give n_bands of at least {order + 2}, or a lower order")
        object.__setattr__(self, "psd_detrend_order", order)
        object.__setattr__(self, "n_bands", n_bands)
        object.__setattr__(self, "weights", _checked_weights(self.weights))

    @property
    def segments_s(self) -> dict[str, float]:
        """The settings that cut a signal into segments, in seconds: a signal shorter than the longest is compared
        by no view."""
        return {name: getattr(self, name) for name in
                ("welch_segment_s", "envelope_segment_s", "lines_segment_s", "stats_window_s")}

    @classmethod
    def from_config(cls, cfg) -> "CompareSettings":
        """Settings from a mapping (the ``compare`` config block); unknown keys are an error."""
        known = {f.name for f in fields(cls)}
        values = dict(cfg or {})
        unknown = set(values) - known
        if unknown:
            raise BearingTwinError(f"compare.{sorted(unknown)[0]} is not a comparison setting; known: {sorted(known)}")
        if "weights" in values:  # a view left out weighs nothing
            weights = dict(values["weights"])
            values["weights"] = {**{view: 0.0 for view in VIEWS}, **weights}
        return cls(**values)


@dataclass
class Profile:
    """Everything a view needs from one signal, computed once per signal."""

    psd_freqs_hz: np.ndarray
    psd: np.ndarray
    band_db: np.ndarray
    lines_freqs_hz: np.ndarray
    lines_psd: np.ndarray       # averaged periodogram at the lines view's bins
    lines_level: np.ndarray     # its local level there (a low running percentile): what a line stands out of
    env_freqs_hz: np.ndarray
    env_amplitude: np.ndarray
    env_db: np.ndarray
    line_db: np.ndarray
    widths_hz: np.ndarray
    windows: np.ndarray

    @cached_property
    def statistics(self) -> np.ndarray:
        """The time-domain features' medians over the windows (a measurement's, once for every twin)."""
        return np.median(time_domain_features(self.windows), axis=0)


@dataclass
class ViewResult:
    """One view's error (dB RMS over ``n_points`` compared values), its share of the overall
    discrepancy, and what it saw."""

    name: str
    error_db: float
    share: float
    finding: str
    n_points: int
    what_leaves_it: str | None = None  # the physics that leaves what it saw, where the view can tell (None: the view's own)


@dataclass
class Comparison:
    """The outcome of holding a twin against a measurement."""

    discrepancy_db: float
    gain: float
    views: dict[str, ViewResult]
    measured: Profile
    twin: Profile
    context: "Comparator"

    @property
    def summary(self) -> str:
        """Where the twin fails, largest share first: the sentence the CLI prints."""
        ranked = sorted(self.views.values(), key=lambda v: -v.share)
        shares = ", ".join(f"{v.name} {100 * v.share:.0f}%" for v in ranked)
        findings = "; ".join(v.finding for v in ranked[:2] if v.share > 0)
        return f"discrepancy {self.discrepancy_db:.2f} dB ({shares}): {findings}"

    def as_dict(self) -> dict:
        """JSON-ready numbers of the comparison."""
        return {
            "discrepancy_db": self.discrepancy_db,
            "gain": self.gain,
            "views": {name: {"error_db": view.error_db, "share": view.share, "finding": view.finding,
                             "n_points": view.n_points}
                      for name, view in self.views.items()},
            "summary": self.summary,
        }


_POSITIVE_SETTINGS = {"welch_segment_s": "seconds", "band_min_hz": "Hz", "dynamic_range_db": "dB",
                      "envelope_segment_s": "seconds", "envelope_highpass_hz": "Hz", "envelope_dynamic_range_db": "dB",
                      "lines_segment_s": "seconds", "lines_max_hz": "Hz", "line_threshold_db": "dB",
                      "stats_window_s": "seconds"}


def _checked_weights(weights) -> dict[str, float]:
    """``compare.weights`` checked, one per view, scaled to a mean of 1: they say how the views weigh against each
    other; how many values the views count as in the ranking's criterion is ``ranking.points_per_view``'s to say."""
    weights = dict(weights)
    bad = set(weights) - set(VIEWS)
    if bad:
        raise BearingTwinError(f"compare.weights.{sorted(bad)[0]} is not a view; views: {', '.join(VIEWS)}")
    for view, weight in weights.items():
        if not (is_finite_number(weight) and weight >= 0):
            raise BearingTwinError(f"compare.weights.{view} must be a non-negative number, got {weight!r}")
    missing = [view for view in VIEWS if view not in weights]
    if missing:
        raise BearingTwinError(f"compare.weights.{missing[0]} is missing: give every view a weight (0: left out)")
    total = sum(weights.values())
    if not total > 0:
        raise BearingTwinError("compare.weights must not all be zero")
    return {view: len(VIEWS) * float(weights[view]) / total for view in VIEWS}


def _db(power_ratio: np.ndarray, dynamic_range_db: float) -> np.ndarray:
    return 10.0 * np.log10(np.maximum(power_ratio, 10 ** (-dynamic_range_db / 10.0)))


def rms_widths_hz(freqs_hz: np.ndarray, amplitude: np.ndarray, centres_hz: np.ndarray, reach_hz: float,
                  floor: float) -> np.ndarray:
    """Twice the RMS spread in Hz of the power above ``floor`` within ``reach_hz`` of each centre.

    A second moment rather than a half-power crossing: a line smeared into several
    jagged bumps (slip, speed fluctuation) has no clean half-power points, but its power
    still spreads, and the moment does not jump when one bump crosses a threshold. A line
    sharper than the bin spacing gets at least one bin.
    """
    df = freqs_hz[1] - freqs_hz[0]
    widths = np.empty(len(centres_hz))
    for i, centre in enumerate(centres_hz):
        near = np.abs(freqs_hz - centre) <= reach_hz
        power = np.clip(amplitude[near] ** 2 - floor**2, 0.0, None)
        total = power.sum()
        if total <= 0:
            widths[i] = 2 * reach_hz
            continue
        mean = np.sum(power * freqs_hz[near]) / total
        widths[i] = max(2 * math.sqrt(np.sum(power * (freqs_hz[near] - mean) ** 2) / total), df)
    return widths


class Comparator:
    """A measurement prepared once, against which any number of twins are compared.

    Calibration compares hundreds of twins to one measurement, so the measurement's
    profile and the frequencies to look at are computed here, once.
    """

    def __init__(self, measured: Recording, geometry: BearingGeometry, settings: CompareSettings | None = None):
        self.settings = settings or CompareSettings()
        self.fs = float(measured.fs)
        for fact in ("rpm", "fault"):
            if getattr(measured, fact) is None:
                raise BearingTwinError(f"{measured.source}: measured.{fact} is needed to compare with the twin")
        self.fault = check_fault(measured.fault)
        self.rpm = float(measured.rpm)
        rates = geometry.defect_frequencies(self.rpm)
        self.reference_name = _REFERENCE_NAME[self.fault]
        self.defect_lines_hz = {name: rates[name.lower()] for name in DEFECT_LINES}
        self.reference_hz = geometry.fault_frequency_hz(self.fault, self.rpm) or rates["shaft"]
        sideband_hz = {"inner": rates["shaft"], "ball": rates["ftf"]}.get(self.fault)
        s = self.settings
        harmonics = self.reference_hz * np.arange(1, s.n_harmonics + 1)
        self.harmonics_hz = harmonics
        self.sidebands_hz = (
            np.concatenate([harmonics - sideband_hz, harmonics + sideband_hz]) if sideband_hz else np.empty(0)
        )
        self.env_max_hz = (s.n_harmonics + 0.5) * self.reference_hz
        self.width_reach_hz = 0.4 * min(self.reference_hz, sideband_hz or self.reference_hz)
        if self.env_max_hz >= self.fs / 2:
            raise BearingTwinError(
                f"measured.fs={self.fs:g} Hz is too low: the envelope view needs {s.n_harmonics} harmonics of "
                f"{self.reference_name} ({self.reference_hz:.1f} Hz), i.e. fs above {2 * self.env_max_hz:.0f} Hz"
            )
        self.segment = int(round(s.envelope_segment_s * self.fs))
        self.env_df = self.fs / self.segment
        if self.env_df > self.reference_hz / 4:
            # A line this low is most often a speed given in Hz, not a slow machine: the speed is named with it.
            raise BearingTwinError(
                f"{measured.source}: compare.envelope_segment_s={s.envelope_segment_s} resolves only "
                f"{self.env_df:.1f} Hz, too coarse for {self.reference_name} at {self.reference_hz:.1f} Hz, where "
                f"{self.rpm:g} rev/min puts it (a speed given in Hz? {self.rpm:g} Hz is {60 * self.rpm:g} rev/min); "
                "for a shaft that slow, give a longer compare.envelope_segment_s"
            )
        if not 0 < s.envelope_highpass_hz < self.fs / 2:
            raise BearingTwinError(
                f"compare.envelope_highpass_hz={s.envelope_highpass_hz} must lie between 0 and "
                f"fs/2 = {self.fs / 2:g} Hz"
            )
        self.highpass = sps.butter(4, s.envelope_highpass_hz, "highpass", fs=self.fs, output="sos")
        self.nperseg = int(round(s.welch_segment_s * self.fs))
        # Windows and transforms made once: hundreds of twins are profiled against one measurement.
        self.psd_welch = WelchPSD(self.fs, sps.get_window("hann", self.nperseg))
        self.band_edges_hz = np.geomspace(s.band_min_hz, self.fs / 2, s.n_bands + 1)
        psd_freqs = self.psd_welch.freqs_hz
        self.band_of_bin = np.searchsorted(self.band_edges_hz, psd_freqs, side="right") - 1
        self.band_of_bin[psd_freqs >= self.fs / 2] = s.n_bands - 1
        self.in_bands = self.band_of_bin >= 0
        empty = np.setdiff1d(np.arange(s.n_bands), self.band_of_bin)
        if empty.size:
            lo, hi = self.band_edges_hz[empty[0]], self.band_edges_hz[empty[0] + 1]
            raise BearingTwinError(
                f"compare.band_min_hz={s.band_min_hz}: the band {lo:.0f}-{hi:.0f} Hz holds no Welch bin at "
                f"{self.fs / self.nperseg:.1f} Hz resolution; raise band_min_hz or welch_segment_s"
            )
        self.envelope_window = sps.get_window("hann", self.segment)
        self.stats_window = int(round(s.stats_window_s * self.fs))
        measured.require_no_held_stretch(s.stats_window_s, f"the comparison's {s.stats_window_s:g} s statistics windows")
        self.lines_nperseg = int(round(s.lines_segment_s * self.fs))
        self.lines_welch = WelchPSD(self.fs, sps.get_window("blackmanharris", self.lines_nperseg))
        lines_freqs = self.lines_welch.freqs_hz
        self.lines_bins = (lines_freqs >= 0.25 * self.rpm / 60.0) & (lines_freqs <= min(s.lines_max_hz, self.fs / 2))
        self.lines_first_bin = int(np.argmax(lines_freqs >= 0.25 * self.rpm / 60.0))
        # A faulty bearing's own lines are the envelope and harmonics views' business: its defect's (its rate's
        # harmonics and their sidebands), and the balls' passing through the load zone (varying compliance:
        # BPFO's harmonics). In the raw spectrum their sharpness and height hang on slip the bare twin lacks and
        # on its contact model, and counting them here too would let the bearing's own model form outvote the
        # lines other machine elements leave. A healthy bearing's ball-pass lines are counted: a real one's
        # roughness and noise bury them, and only where the lines view sees them standing in the bare twin can a
        # noise floor pay on a healthy record; a twin keeping them is no healthy bearing of the rig, and a
        # classifier trained on it calls faults healthy (results/identifiability.md, results/sim2real.md).
        if self.fault == "normal":
            own = np.empty(0)
        else:
            ball_pass = rates["bpfo"] * np.arange(1, int(s.lines_max_hz // rates["bpfo"]) + 2)
            orders = self.reference_hz * np.arange(1, int(s.lines_max_hz // self.reference_hz) + 2)
            defect = [orders, orders - sideband_hz, orders + sideband_hz] if sideband_hz else [orders]
            own = np.concatenate([ball_pass, *defect])
        reach = 4 * lines_freqs[1] + 0.01 * own  # the window's main lobe, and 1 % for slip and speed
        self.lines_bins &= ~np.any(np.abs(lines_freqs[:, None] - own) <= reach, axis=1)
        self.band_centres_log = np.log10(np.sqrt(self.band_edges_hz[:-1] * self.band_edges_hz[1:]))
        self.line_hz = np.concatenate([harmonics, self.sidebands_hz])
        self.measured_signal = np.asarray(measured.signal, dtype=np.float64)
        try:
            self.measured = self.profile(self.measured_signal)
        except BearingTwinError as error:
            raise BearingTwinError(f"{measured.source}: {error}") from None

    def _tolerance_hz(self, centre_hz: float) -> float:
        """Search half-width for a line: enough for rpm uncertainty and slip, never reaching a sideband."""
        return min(max(1.5 * self.env_df, 0.01 * centre_hz), 0.4 * self.reference_hz)

    def profile(self, x: np.ndarray) -> Profile:
        """The statistics every view compares, for one signal at the measurement's fs."""
        x = np.asarray(x, dtype=np.float64)
        s = self.settings
        if x.size < max(self.segment, self.nperseg, self.stats_window, self.lines_nperseg):
            raise BearingTwinError(
                f"a signal of {x.size / self.fs:.3f} s is shorter than one comparison segment "
                f"(compare.envelope_segment_s={s.envelope_segment_s}, welch_segment_s={s.welch_segment_s}, "
                f"lines_segment_s={s.lines_segment_s})"
            )
        psd_freqs, psd = self.psd_welch(x)
        band_power = np.bincount(self.band_of_bin[self.in_bands], weights=psd[self.in_bands], minlength=s.n_bands)
        band_db = _db(band_power / band_power.max(), s.dynamic_range_db) + 10 * np.log10(band_power.max())
        # Blackman-Harris leaks less than 92 dB beyond 4 bins, and the spectrum is floored at the
        # dynamic range, so a strong line of a noiseless twin has no skirt of "lines" beside it.
        lines_freqs, lines_psd = self.lines_welch(x)
        lines_psd = np.maximum(lines_psd, lines_psd.max() * 10 ** (-s.dynamic_range_db / 10.0))
        # The level from the lowest bin the view reads up: below it the removed mean and the window's leakage leave a
        # dip towards 0 Hz that a low percentile would take for the floor of the lowest lines.
        lowest = self.lines_first_bin
        lines_level = np.empty_like(lines_psd)
        lines_level[lowest:] = local_level(lines_psd[lowest:], s.line_level_bins, s.line_level_percentile)
        lines_level[:lowest] = lines_level[lowest]
        n_segments = max(1, 2 * x.size // self.segment - 1)
        segments, _ = cut_windows(sps.sosfiltfilt(self.highpass, x), self.segment, n_segments)
        env_freqs, env_amp = envelope_spectrum(segments, self.fs, window=self.envelope_window)
        env_amp = env_amp.mean(axis=0)
        in_range = (env_freqs >= 0.5 * min(self.reference_hz, self.rpm / 60.0)) & (env_freqs <= self.env_max_hz)
        lowest = env_amp[in_range].max() * 10 ** (-s.envelope_dynamic_range_db / 20.0)
        floor = max(np.median(env_amp[in_range]), lowest)
        env_db = 20 * np.log10(np.maximum(env_amp[in_range], lowest) / floor)
        lines = np.array([peak_near(env_freqs, env_amp, f, self._tolerance_hz(f))[1] for f in self.line_hz])
        line_db = 20 * np.log10(np.maximum(lines, lowest) / floor)
        widths = rms_widths_hz(env_freqs, env_amp, self.harmonics_hz, self.width_reach_hz, floor)
        n_windows = max(1, x.size // self.stats_window)
        windows, _ = cut_windows(x, self.stats_window, n_windows)
        return Profile(psd_freqs, psd, band_db, lines_freqs[self.lines_bins], lines_psd[self.lines_bins],
                       lines_level[self.lines_bins], env_freqs, env_amp, env_db, line_db, widths, windows)

    def __call__(self, twin: Recording | np.ndarray, other: str = "the twin") -> Comparison:
        """Compare a twin signal (same fs as the measurement) with the measurement; ``other`` names it in the
        findings (another record of the rig compares the same way: "the reference record")."""
        if isinstance(twin, Recording):
            if not math.isclose(twin.fs, self.fs):
                raise BearingTwinError(f"{twin.source}: twin fs={twin.fs} differs from the measurement's {self.fs}")
            twin = twin.signal
        return self.compare_profiles(self.profile(twin), other)

    def compare_profiles(self, twin: Profile, other: str = "the twin") -> Comparison:
        """The views' errors between the measurement and an already profiled twin (``other`` in the findings)."""
        m, s = self.measured, self.settings
        residual = m.band_db - twin.band_db
        gain_db = float(residual.mean())
        # The centred log frequencies make the fitted polynomial's mean the gain itself.
        centred = self.band_centres_log - self.band_centres_log.mean()
        residual = residual - np.polyval(np.polyfit(centred, residual, s.psd_detrend_order), centred)
        worst = int(np.argmax(np.abs(residual)))
        lo, hi = self.band_edges_hz[worst], self.band_edges_hz[worst + 1]
        psd_cause = None
        if abs(residual[worst]) < 0.5:
            psd_finding = "band levels agree within 0.5 dB after gain and tilt"
        else:
            psd_finding = (f"energy between {_hz(lo)} and {_hz(hi)} is {abs(residual[worst]):.1f} dB "
                           f"{'above' if residual[worst] > 0 else 'below'} {other}'s")
            if residual[worst] < 0:  # the measurement quieter: what takes energy away, not what adds it
                psd_cause = "a quieter path in that band (more damping, or a mode the twin has and the structure lacks)"
                if worst == residual.size - 1:  # the top band: what every acquisition chain does there
                    psd_cause += (" or, at the top of the spectrum, a low-pass in the measurement chain (the sensor's or "
                                  "the converter's bandwidth, or a record resampled from a lower rate)")

        gain = 10 ** (gain_db / 20.0)
        lines_error, lines_finding, n_line_bins, lines_cause = self._compare_lines(m, twin, gain, other)

        smooth = max(1, int(round(s.smooth_hz / self.env_df)))
        kernel = np.ones(smooth) / smooth
        env_diff = np.convolve(m.env_db - twin.env_db, kernel, mode="same")
        env_error = float(np.sqrt(np.mean(env_diff**2)))
        env_finding = f"the envelope spectrum up to {_hz(self.env_max_hz)} differs by {env_error:.1f} dB RMS"

        line_diff = m.line_db - twin.line_db
        width_ratio = m.widths_hz / twin.widths_hz
        width_db = 20 * np.log10(width_ratio)
        harmonic_error = float(np.sqrt(np.mean(np.concatenate([line_diff, width_db]) ** 2)))
        k = len(self.harmonics_hz)
        mean_ratio = float(np.exp(np.mean(np.log(width_ratio))))
        prominence = float(np.mean(line_diff[:k]))
        width_words = (f"as wide as {other}'s" if abs(mean_ratio - 1) < 0.1
                       else f"{_times(mean_ratio)} as wide as {other}'s")
        prominence_words = ("equally prominent" if abs(prominence) < 0.5 else
                            f"{abs(prominence):.1f} dB {'more' if prominence >= 0 else 'less'} prominent")
        # The words are means, in which differences of opposite sign cancel; the error is an RMS, so the largest
        # single difference is named as well where it is not small, and the means are then said to be means.
        largest = self._largest_harmonic_difference(line_diff, width_db, other)
        harmonic_finding = (f"in the measurement {self.reference_name} harmonics are {'on average ' if largest else ''}"
                            f"{width_words} and {prominence_words}")
        if self.sidebands_hz.size:
            sideband = float(np.mean(line_diff[k:]))
            harmonic_finding += ("; sidebands as strong" if abs(sideband) < 0.5 else
                                 f"; sidebands {abs(sideband):.1f} dB {'stronger' if sideband >= 0 else 'weaker'}")
        harmonic_finding += largest

        stat_db, stat_names = [], []
        for name, fm, ft in zip(FEATURE_NAMES, m.statistics, twin.statistics):
            if name not in STATISTICS_FEATURES:
                continue
            per_decade = _FEATURE_DB_PER_DECADE.get(name, 20.0)
            stat_db.append(per_decade * math.log10(max(fm, 1e-300) / max(ft, 1e-300)))
            stat_names.append(name)
        stat_db = np.array(stat_db)
        stat_error = float(np.sqrt(np.mean(stat_db**2)))
        worst_stat = int(np.argmax(np.abs(stat_db)))
        ratio = 10 ** (stat_db[worst_stat] / _FEATURE_DB_PER_DECADE.get(stat_names[worst_stat], 20.0))
        stat_finding = (f"the measurement's {stat_names[worst_stat].replace('_', ' ')} is "
                        f"{_times(ratio)} {other}'s" if abs(ratio - 1) >= 0.05
                        else "kurtosis and the crest, shape, impulse and margin factors agree within 5 %")

        errors = {"psd": float(np.sqrt(np.mean(residual**2))), "lines": lines_error, "envelope": env_error,
                  "harmonics": harmonic_error, "statistics": stat_error}
        findings = {"psd": psd_finding, "lines": lines_finding, "envelope": env_finding,
                    "harmonics": harmonic_finding, "statistics": stat_finding}
        n_points = {"psd": s.n_bands, "lines": n_line_bins, "envelope": max(1, len(env_diff) // smooth),
                    "harmonics": len(line_diff) + len(width_db), "statistics": len(stat_db)}
        weighted = {v: s.weights[v] * errors[v] for v in VIEWS}
        total_weight = sum(s.weights.values())
        discrepancy = sum(weighted.values()) / total_weight
        views = {
            v: ViewResult(v, errors[v], weighted[v] / sum(weighted.values()) if discrepancy > 0 else 0.0, findings[v],
                          n_points[v], {"psd": psd_cause, "lines": lines_cause,
                                        "harmonics": SHAFT_HARMONICS_CAUSE if self.fault == "normal" else None}.get(v))
            for v in VIEWS
        }
        return Comparison(float(discrepancy), gain, views, m, twin, self)

    def _largest_harmonic_difference(self, line_diff: np.ndarray, width_db: np.ndarray, other: str,
                                     least_db: float = 1.0) -> str:
        """The harmonics view's largest single difference in words (a line's height in dB, or a harmonic's width as
        a ratio to ``other``'s), where it reaches ``least_db``; "" otherwise."""
        k = len(self.harmonics_hz)
        differences = np.concatenate([line_diff, width_db])
        worst = int(np.argmax(np.abs(differences)))
        value = float(differences[worst])
        if abs(value) < least_db:
            return ""
        if worst >= len(line_diff):
            n = worst - len(line_diff) + 1
            return f"; most apart, harmonic {n} is {_times(10 ** (value / 20))} as wide as {other}'s"
        if worst < k:
            return f"; most apart, harmonic {worst + 1} is {abs(value):.1f} dB {'more' if value > 0 else 'less'} prominent"
        side = worst - k  # the sidebands below the harmonics, then those above (``line_hz``)
        return (f"; most apart, the sideband {'below' if side < k else 'above'} harmonic {side % k + 1} is "
                f"{abs(value):.1f} dB {'stronger' if value > 0 else 'weaker'}")

    def line_heights_db(self, m: Profile, twin: Profile, gain: float) -> tuple[np.ndarray, np.ndarray]:
        """How far each bin stands above ``line_threshold_db`` over the local level, in dB (0 where it
        does not): measurement and twin (at ``gain``).

        Both are measured over the *measurement's* local level, so two rigs whose broadband
        floors differ (a twin has almost none) agree on a line of one size; a bin counts as a
        line of the twin only where it also stands out of the twin's own local level. Measuring
        the excess over the threshold rather than cutting at it keeps the value continuous as a
        line grows.
        """
        threshold = self.settings.line_threshold_db
        measured = np.maximum(10 * np.log10(m.lines_psd / m.lines_level) - threshold, 0.0)
        own = 10 * np.log10(twin.lines_psd / twin.lines_level)
        over_measured = 10 * np.log10(gain**2 * twin.lines_psd / m.lines_level)
        return measured, np.maximum(np.minimum(own, over_measured) - threshold, 0.0)

    @cached_property
    def measured_lines_spectrum(self) -> tuple[np.ndarray, np.ndarray]:
        """The measurement's lines spectrum over every bin, the bands the lines view leaves out among them (Hz, PSD)."""
        return self.lines_welch(self.measured_signal)

    def _beside_a_band_left_out(self, hz: float) -> bool:
        """Whether the lines view's bin at ``hz`` borders a band it leaves out (a faulty bearing's own lines)."""
        index = int(round(hz / self.lines_welch.freqs_hz[1]))
        kept = np.flatnonzero(self.lines_bins)
        return bool(kept.size) and kept[0] < index < kept[-1] and not (self.lines_bins[index - 1] and self.lines_bins[index + 1])

    def _compare_lines(self, m: Profile, twin: Profile, gain: float,
                       other: str = "the twin") -> tuple[float, str, int, str | None]:
        """Root of the summed squared line-height differences, per line bin of the measurement; the finding; the
        number of line bins; what leaves the worst line where its frequency tells (:func:`line_source`).

        Bins where neither signal has a line are equal (0) by construction; dividing by the
        measurement's own number of line bins (fixed, whatever the twin) keeps the error
        continuous as a twin's line rises through the threshold, and makes a few lines weigh
        the same in a wide band as in a narrow one.
        """
        measured, twin_heights = self.line_heights_db(m, twin, gain)
        diff = measured - twin_heights
        n_lines = max(int(np.count_nonzero(measured)), 1)
        if not np.any(diff):
            return 0.0, "the narrow lines agree", n_lines, None
        worst = int(np.argmax(np.abs(diff)))
        peak = _line_peak(worst, measured if diff[worst] > 0 else twin_heights, measured, twin_heights)
        # Between bins (2 Hz apart at the default 0.5 s segments): a 25 Hz shaft line is named at 25 Hz, not 26.
        df = m.lines_freqs_hz[1] - m.lines_freqs_hz[0]
        freq, _ = peak_near(m.lines_freqs_hz, (m if diff[worst] > 0 else twin).lines_psd, m.lines_freqs_hz[peak], df)
        if diff[worst] > 0 and self._beside_a_band_left_out(m.lines_freqs_hz[peak]):
            # A line whose peak lies in a band left to the envelope views (twice a 50 Hz supply beside BPFO at 107 Hz)
            # shows only its skirt here: named where its peak stands in the measurement's whole spectrum (100 Hz, not 98).
            freqs_hz, psd = self.measured_lines_spectrum
            freq, _ = peak_near(freqs_hz, psd, m.lines_freqs_hz[peak], 2 * df)
        finding = (f"a line at {freq:.0f} Hz (shaft order {freq / (self.rpm / 60.0):.2f}) stands {abs(diff[worst]):.0f} dB "
                   f"{'higher in the measurement' if diff[worst] > 0 else 'higher in ' + other}")
        cause = (line_source(freq, self.rpm / 60.0, df, self.defect_lines_hz, _REFERENCE_NAME[self.fault])
                 if diff[worst] > 0 else TWIN_LINE_TOO_STRONG)
        return float(np.sqrt(np.sum(diff**2) / n_lines)), finding, n_lines, cause


DEFECT_LINES = {"BPFO": "the outer race", "BPFI": "the inner race", "BSF": "a ball"}
"""The bearing's defect frequencies a line may stand on, and the part whose defect makes it."""


def line_source(freq_hz: float, shaft_hz: float, resolution_hz: float, defect_hz: Mapping[str, float] | None = None,
                own: str | None = None) -> str | None:
    """What leaves a line the measurement adds at ``freq_hz``, where its place tells: on one of the shaft's first
    orders or half orders (``shaft_hz``: the shaft rate; up to 3x, where such a line is most likely the shaft's),
    on one of the bearing's defect frequencies' first three harmonics (``defect_hz``: BPFO, BPFI, BSF in Hz;
    ``own``: the one of the record's stated fault, ``shaft`` for a healthy one), or on one of a supply's first four multiples; None elsewhere
    (the lines view's general answer stands), and where the spectrum's bins (``resolution_hz``) are too coarse to
    tell a shaft order from the next half order. On means within half a bin plus 0.5 % of the frequency (the
    line's frequency is read between bins)."""
    if resolution_hz >= shaft_hz / 4:
        return None

    def on(target_hz: float) -> bool:
        return abs(freq_hz - target_hz) <= resolution_hz / 2 + 0.005 * target_hz

    half = round(2 * freq_hz / shaft_hz) / 2
    words = None
    if 0.5 <= half <= 3 and on(half * shaft_hz):
        words = {1.0: "a force once per revolution: unbalance, a bent shaft, or a misalignment's 1x",
                 2.0: "a force twice per revolution: misalignment, or looseness",
                 3.0: "a force three times per revolution: misalignment, or looseness"}.get(
            half, "a machine that makes half orders: looseness or a rub")
    # A defect's line in the spectrum itself (not only its envelope): a second defect, or the stated one stronger.
    defect = next(((name, k) for name, hz in (defect_hz or {}).items() for k in (1, 2, 3) if on(k * hz)), None)
    if defect is not None and words is None:
        name, k = defect
        order = name if k == 1 else f"{k} x {name}"
        words = (f"this bearing's {order} ({DEFECT_LINES[name]}'s defect frequency"
                 + ("): the stated defect rings stronger in this line than the twin's does" if name == own else
                    f"): a defect on {DEFECT_LINES[name]}, though the record is stated healthy" if own == "shaft" else
                    f"): a defect on {DEFECT_LINES[name]} as well, or a record of another state than the one stated"))
    supply = next(((n, f) for f in MAINS_HZ for n in range(1, 5) if on(n * f)), None)
    if supply is not None:
        n, mains = supply
        electrical = (f"an electrical line at {n} x a {mains:.0f} Hz supply "
                      + ("(a motor's magnetic pull)" if n == 2 else "(pickup from the supply or the drive)"))
        return f"{words}, or {electrical} (the two lie too close here to tell apart)" if words else electrical
    return words


SHAFT_HARMONICS_CAUSE = ("a modulation once per revolution, which a healthy bearing's defect-free model does not make: "
                         "unbalance, misalignment, a bent shaft or looseness")
"""What leaves the shaft's harmonics in a healthy record's envelope (its harmonics view reads the shaft's, no defect's)."""

TWIN_LINE_TOO_STRONG = ("a line the twin makes and the machine does not, or not as strongly: an effect of the "
                        "twin's at that frequency set too strong, or a line of the twin's own bearing model that the "
                        "machine's noise and roughness bury")
"""What leaves a line that stands higher in the twin than in the measurement."""


def _line_peak(bin_index: int, heights: np.ndarray, *signals: np.ndarray) -> int:
    """The bin where the line holding ``bin_index`` peaks in ``heights``: a strong line's window skirt spans several
    bins either side, and the largest difference may fall on a skirt (a 30 Hz line named at 36 Hz). A line is the
    run of neighbouring bins where any of ``signals`` stands out."""
    standing = np.any([signal > 0 for signal in signals], axis=0)
    low = high = bin_index
    while low > 0 and standing[low - 1]:
        low -= 1
    while high < standing.size - 1 and standing[high + 1]:
        high += 1
    return low + int(np.argmax(heights[low:high + 1]))


def local_level(psd: np.ndarray, neighbourhood_bins: int = 21, percentile: float = 50.0) -> np.ndarray:
    """The level a narrow line stands out of: a percentile (50: the median) of each bin's neighbourhood of a
    power spectrum (a line occupies a few of its bins, so it does not lift it). Along the last axis."""
    psd = np.maximum(np.asarray(psd, dtype=np.float64), np.finfo(float).tiny)
    return percentile_filter(psd, percentile, size=neighbourhood_bins, axes=(-1,), mode="nearest")


def _hz(f: float) -> str:
    return f"{f / 1000:.2g} kHz" if f >= 1000 else f"{f:.0f} Hz"


def _times(ratio: float) -> str:
    """A ratio as an engineer writes it: "2.3 times", "0.45 times"."""
    return f"{ratio:.2g} times"


def plot_comparison(comparison: Comparison, out_dir: str | Path, prefix: str = "compare") -> list[Path]:
    """One PNG per view (Agg backend), named ``<prefix>_<view>.png``, overlaying twin and measurement."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    c, m, t = comparison.context, comparison.measured, comparison.twin
    power_gain = comparison.gain**2
    paths = []

    def save(fig, view):
        result = comparison.views[view]
        # A finding runs to two hundred characters: wrapped, not cut off at the figure's edges.
        fig.suptitle(textwrap.fill(f"{view}: {result.error_db:.2f} dB -- {result.finding}", 120), fontsize=8)
        fig.tight_layout()
        path = out_dir / f"{prefix}_{view}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)

    fig, ax = plt.subplots(figsize=(8, 4))
    ax.semilogy(m.psd_freqs_hz, m.psd, lw=0.8, label="measurement")
    ax.semilogy(t.psd_freqs_hz, power_gain * t.psd, lw=0.8, label=f"twin x gain {comparison.gain:.3g}")
    for edge in c.band_edges_hz:
        ax.axvline(edge, color="0.85", lw=0.5)
    ax.set_xscale("log")
    ax.set(xlabel="frequency (Hz)", ylabel="PSD (unit^2/Hz)")
    ax.legend(fontsize=8)
    save(fig, "psd")

    fig, ax = plt.subplots(figsize=(8, 4))
    measured_heights, twin_heights = c.line_heights_db(m, t, comparison.gain)
    # The bins the view leaves out (the bearing's own lines) are gaps, not straight lines drawn across them.
    gaps = np.flatnonzero(np.diff(m.lines_freqs_hz) > 1.5 * np.min(np.diff(m.lines_freqs_hz))) + 1
    freqs = np.insert(m.lines_freqs_hz, gaps, np.nan)
    ax.plot(freqs, np.insert(measured_heights, gaps, np.nan), lw=0.8, label="measurement")
    ax.plot(freqs, np.insert(twin_heights, gaps, np.nan), lw=0.8, label=f"twin x gain {comparison.gain:.3g}")
    shaft_hz = c.rpm / 60.0
    for order in np.arange(0.5, m.lines_freqs_hz[-1] / shaft_hz, 0.5):
        ax.axvline(order * shaft_hz, color="0.85" if order % 1 else "0.6", lw=0.5)
    ax.set(xlabel="frequency (Hz); grey: shaft orders and half orders",
           ylabel=f"line height (dB over {c.settings.line_threshold_db:g} dB\nabove the measurement's local level)")
    ax.legend(fontsize=8)
    save(fig, "lines")

    for view in ("envelope", "harmonics"):
        fig, ax = plt.subplots(figsize=(8, 4))
        keep = m.env_freqs_hz <= c.env_max_hz
        ax.plot(m.env_freqs_hz[keep], m.env_amplitude[keep] / m.env_amplitude[keep].max(), lw=0.8, label="measurement")
        ax.plot(t.env_freqs_hz[keep], t.env_amplitude[keep] / t.env_amplitude[keep].max(), lw=0.8, label="twin")
        for k, f in enumerate(c.harmonics_hz, start=1):
            ax.axvline(f, color="r", ls="--", lw=0.6)
            ax.text(f, 1.02, f"{k}x{c.reference_name}", fontsize=6, ha="center")
            if view == "harmonics":
                ax.axvspan(f - m.widths_hz[k - 1] / 2, f + m.widths_hz[k - 1] / 2, color="C0", alpha=0.2)
                ax.axvspan(f - t.widths_hz[k - 1] / 2, f + t.widths_hz[k - 1] / 2, color="C1", alpha=0.2)
        for f in c.sidebands_hz:
            ax.axvline(f, color="g", ls=":", lw=0.6)
        ax.set(xlabel="frequency (Hz)", ylabel="envelope amplitude (normalised)")
        ax.legend(fontsize=8)
        save(fig, view)

    features_m = time_domain_features(m.windows)
    features_t = time_domain_features(t.windows)
    fig, axes = plt.subplots(1, len(STATISTICS_FEATURES), figsize=(10, 3))
    for ax, name in zip(axes, STATISTICS_FEATURES):
        i = FEATURE_NAMES.index(name)
        ax.boxplot([features_m[:, i], features_t[:, i]])
        ax.set_xticks([1, 2], ["meas", "twin"], fontsize=6)
        ax.set_title(name, fontsize=7)
        ax.tick_params(labelsize=6)
    save(fig, "statistics")
    return paths
