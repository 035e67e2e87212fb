"""Envelope-order features: how the envelope's power is shared among the bearing's defect orders.

Why these and not the nine time-domain features: a twin calibrated on one outer-race record
does not know how hard an inner-race or ball impact hits, nor the gain of the path to the
sensor, so kurtosis, crest factor and the like (which scale with impact severity) land the
real windows far from the twin's. Where the impacts *repeat* is pure kinematics - geometry
and shaft speed - and the twin gets it right (results/figure10.png). So each window is
band-passed where the impacts ring, demodulated, and its envelope spectrum is read on the
shaft-order axis (frequency / shaft rate, so the features do not move with load or speed);
each feature is the fraction of the envelope's power in a narrow band around one defect
order. Fractions of a total are invariant to gain, and a harder or softer impact changes
the total more than how it is shared.

The band-pass is fixed as a fraction of the Nyquist rate (default 0.25-0.9, i.e. 1.5-5.4 kHz
at CWRU's 12 kHz): above the shaft harmonics and gear/electrical lines that dominate the low
band, and covering the housing resonances where impacts ring (the twin study on record 130
placed one at 3.7 kHz).

The shares of the envelope say *which* defect repeats, not *whether* anything rings at all: a
healthy bearing's envelope is noise, shared out as evenly as a faint fault's. So one more
feature (``band_power``) is how much of the window's power lies in that band-pass, in log10:
a localized defect's impacts ring the housing's resonances, a healthy bearing puts its power
at the shaft and ball-pass harmonics below it (the high-frequency resonance technique's premise).
It is a ratio of two powers of one window, so it is gain-invariant too.

A share of the total also depends on how wide the envelope spectrum is, which the ringing
resonance's bandwidth sets, a property of the path, not of the defect: the same impacts
through a narrower resonance put larger shares everywhere. ``line_measure="prominence"``
reads each band instead as a line's height above the envelope spectrum's local floor (log10
of its mean power over the median power of the flanks within ``floor_width_orders``), as a
diagnostician reads an envelope spectrum: a line or no line, whatever the floor's level
(``features=envelope_prominence``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.signal
from sklearn.base import BaseEstimator, TransformerMixin

from bearingtwin.checks import is_finite_number
from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import BearingGeometry
from bearingtwin.signal import cepstral_prewhiten, envelope_spectrum

DEFECT_RATES = ("bpfi", "bpfo", "bsf2", "ftf")
"""Repetition rates read from the envelope: bsf2 = 2 x BSF, since a spall on a ball strikes both races per spin."""
LINE_MEASURES = ("share", "prominence")
PREWHITENING = ("none", "cepstral")


def defect_orders(geometry: BearingGeometry) -> dict[str, float]:
    """Each repetition rate in shaft orders (Hz per Hz of shaft rate): speed-independent by construction."""
    per_shaft = geometry.defect_frequencies(60.0)  # 60 rev/min = 1 Hz shaft rate
    return {"bpfi": per_shaft["bpfi"], "bpfo": per_shaft["bpfo"], "bsf2": 2.0 * per_shaft["bsf"], "ftf": per_shaft["ftf"]}


def band_centres(geometry: BearingGeometry, harmonics: int, rates: Sequence[str] = DEFECT_RATES) -> dict[str, float]:
    """Feature name -> centre order: harmonics 1..h of each of ``rates`` (in :data:`DEFECT_RATES`' order), and
    the +-1 shaft-order sidebands of the inner-race harmonics (an inner-race defect turns with the shaft
    through the load zone)."""
    orders = defect_orders(geometry)
    centres = {}
    for rate in (rate for rate in DEFECT_RATES if rate in rates):
        for h in range(1, harmonics + 1):
            centres[f"{h}x{rate}"] = h * orders[rate]
            if rate == "bpfi":
                centres[f"{h}x{rate}-1x"] = h * orders[rate] - 1.0
                centres[f"{h}x{rate}+1x"] = h * orders[rate] + 1.0
    return centres


class EnvelopeOrderFeatures(TransformerMixin, BaseEstimator):
    """Band-passed envelope power in narrow bands around the defect orders: shares of the total, or prominences.

    ``fit`` / ``transform`` take the windows' operating point as keyword arguments, because it
    belongs to the data, not to the extractor: ``fs_hz`` (one rate) and ``rpm`` (one shaft speed
    per window, rev/min, or one for all). In a scikit-learn ``Pipeline`` they travel as metadata::

        sklearn.set_config(enable_metadata_routing=True)
        features = EnvelopeOrderFeatures(bearing=bearing_config("cwru_6205"))
        features.set_fit_request(fs_hz=True, rpm=True).set_transform_request(fs_hz=True, rpm=True)
        pipeline = Pipeline([("features", features), ("svm", SvmClassifier())])
        pipeline.fit(X, y, fs_hz=12000.0, rpm=rpm).predict(X_new, fs_hz=12000.0, rpm=rpm_new)
        cross_val_score(pipeline, X, y, params={"fs_hz": 12000.0, "rpm": rpm})

    Args:
        bearing: the bearing config group (``conf/bearing/*.yaml``): geometry -> defect orders.
        band_nyquist: (low, high) band-pass edges as fractions of the Nyquist rate.
        filter_order: Butterworth order of the band-pass (applied forward and backward: no phase shift).
        harmonics: harmonics of each defect rate.
        rates: the repetition rates read (any of :data:`DEFECT_RATES`, all by default); their columns keep
            that order whatever the order given.
        half_width_orders: half width of each band in shaft orders; widened to at least one
            envelope-spectrum bin so a band never falls between bins.
        band_power: add ``band_power_log10``, log10 of the share of the window's power (about
            its mean) inside the band-pass.
        line_measure: ``share`` (fraction of the envelope's power in each band) or
            ``prominence`` (log10 of the band's mean power over the median of its flanks).
        floor_width_orders: width in shaft orders of each flank that sets a prominence's floor,
            beyond the band's half width on either side.
        prewhiten: ``none`` or ``cepstral``: the lines are read from the envelope of the
            cepstrally pre-whitened window (:func:`bearingtwin.signal.cepstral_prewhiten`), which
            no longer carries the transfer path's spectral shape; ``band_power`` is always the raw
            window's.

    Fitted attributes:
        feature_names_: one name per column (``<h>x<rate>``, the inner-race sidebands, then
            ``band_power_log10`` when ``band_power``).
        band_hz_: the band-pass edges in Hz at the fitted rate.
    """

    def __init__(self, bearing: dict | None = None, band_nyquist: tuple[float, float] = (0.25, 0.9),
                 filter_order: int = 4, harmonics: int = 3, half_width_orders: float = 0.15,
                 band_power: bool = True, line_measure: str = "share", floor_width_orders: float = 1.0,
                 prewhiten: str = "none", rates: Sequence[str] = DEFECT_RATES) -> None:
        self.bearing = bearing
        self.band_nyquist = band_nyquist
        self.filter_order = filter_order
        self.harmonics = harmonics
        self.rates = rates
        self.half_width_orders = half_width_orders
        self.band_power = band_power
        self.line_measure = line_measure
        self.floor_width_orders = floor_width_orders
        self.prewhiten = prewhiten

    def __setstate__(self, state: dict) -> None:
        # A model registered before ``rates`` existed read every rate: it keeps doing so when loaded.
        super().__setstate__({"rates": DEFECT_RATES, **state})

    def check_params(self) -> BearingGeometry:
        """The bearing's geometry, after checking every parameter (errors name the parameter)."""
        if not self.bearing:
            raise BearingTwinError("features.bearing: envelope-order features need the bearing geometry (bearing: ${bearing})")
        band = list(self.band_nyquist) if isinstance(self.band_nyquist, Sequence) and not isinstance(
            self.band_nyquist, str) else [self.band_nyquist]
        if not (len(band) == 2 and all(is_finite_number(v) for v in band) and 0.0 < band[0] < band[1] < 1.0):
            raise BearingTwinError(f"features.band_nyquist={band}: need two numbers 0 < low < high < 1 (fractions of Nyquist)")
        if not (isinstance(self.filter_order, int) and self.filter_order > 0):
            raise BearingTwinError(f"features.filter_order must be a positive integer, got {self.filter_order!r}")
        if not (isinstance(self.harmonics, int) and self.harmonics > 0):
            raise BearingTwinError(f"features.harmonics must be a positive integer, got {self.harmonics!r}")
        self.rate_names()
        if not (is_finite_number(self.half_width_orders) and self.half_width_orders > 0):
            raise BearingTwinError(f"features.half_width_orders must be positive, got {self.half_width_orders!r}")
        if not isinstance(self.band_power, bool):
            raise BearingTwinError(f"features.band_power must be true or false, got {self.band_power!r}")
        if self.line_measure not in LINE_MEASURES:
            raise BearingTwinError(f"features.line_measure={self.line_measure!r}: choose one of {', '.join(LINE_MEASURES)}")
        if self.prewhiten not in PREWHITENING:
            raise BearingTwinError(f"features.prewhiten={self.prewhiten!r}: choose one of {', '.join(PREWHITENING)}")
        if not (is_finite_number(self.floor_width_orders) and self.floor_width_orders > 0):
            raise BearingTwinError(f"features.floor_width_orders must be positive, got {self.floor_width_orders!r}")
        return BearingGeometry.from_config(self.bearing)

    def rate_names(self) -> tuple[str, ...]:
        """``rates`` as a tuple of names, checked (a single name is one rate, not its letters)."""
        rates = (self.rates,) if isinstance(self.rates, str) else tuple(self.rates) if isinstance(self.rates, Sequence) else ()
        if not rates or any(rate not in DEFECT_RATES for rate in rates) or len(set(rates)) < len(rates):
            raise BearingTwinError(f"features.rates={self.rates!r}: give one or more of {', '.join(DEFECT_RATES)}, each once")
        return rates

    def bands_on_shaft_harmonics(self) -> list[str]:
        """The line features whose band (centre +- ``half_width_orders``) holds a whole shaft order: every
        machine's envelope carries shaft harmonics, so on such a bearing those features read the shaft's
        lines as well as the defect's (the SKF 6203's 2 x BSF is 3.988 orders, its BPFO 3.053)."""
        half_width = float(self.half_width_orders)
        return [name for name, centre in band_centres(self.check_params(), self.harmonics, self.rate_names()).items()
                if round(centre) >= 1 and abs(centre - round(centre)) <= half_width]

    def fit(self, X, y=None, *, fs_hz: float, rpm) -> "EnvelopeOrderFeatures":
        """Nothing is learned from the windows: fixes the band in Hz and the feature names."""
        geometry = self.check_params()
        X, _ = self._check(X, fs_hz, rpm)
        self.band_hz_ = tuple(float(v) * fs_hz / 2.0 for v in self.band_nyquist)
        self.feature_names_ = (list(band_centres(geometry, self.harmonics, self.rate_names()))
                               + (["band_power_log10"] if self.band_power else []))
        return self

    def transform(self, X, y=None, *, fs_hz: float, rpm) -> np.ndarray:
        """(n_windows, n_features): each band's share of the envelope's power (excluding DC) or its prominence."""
        if not hasattr(self, "band_hz_"):
            raise BearingTwinError("EnvelopeOrderFeatures: call fit before transform")
        if not np.isclose(fs_hz, 2.0 * self.band_hz_[1] / float(self.band_nyquist[1])):
            raise BearingTwinError(f"fs_hz={fs_hz}: the extractor was fitted at a different sampling rate")
        X, shaft_hz = self._check(X, fs_hz, rpm)
        sos = scipy.signal.butter(self.filter_order, self.band_hz_, btype="bandpass", fs=fs_hz, output="sos")
        in_band = scipy.signal.sosfiltfilt(sos, X, axis=-1)
        lines_from = scipy.signal.sosfiltfilt(sos, cepstral_prewhiten(X), axis=-1) if self.prewhiten == "cepstral" else in_band
        freqs_hz, amplitude = envelope_spectrum(lines_from, fs_hz, window="hann")
        power = amplitude[:, 1:] ** 2
        orders = freqs_hz[None, 1:] / shaft_hz[:, None]
        half_width = np.maximum(float(self.half_width_orders), (freqs_hz[1] - freqs_hz[0]) / shaft_hz)[:, None]
        total = power.sum(axis=1)
        if np.any(total == 0):
            raise BearingTwinError("X: a window has no envelope power in the band-pass, so its power cannot be shared out")
        columns = []
        for centre in band_centres(self.check_params(), self.harmonics, self.rate_names()).values():
            distance = np.abs(orders - centre)
            in_line = distance <= half_width
            if self.line_measure == "share":
                columns.append(np.where(in_line, power, 0.0).sum(axis=1) / total)
                continue
            flanks = ~in_line & (distance <= half_width + float(self.floor_width_orders))
            unread = ~(flanks.any(axis=1) & in_line.any(axis=1))
            if np.any(unread):
                rpm_unread = float(shaft_hz[np.argmax(unread)]) * 60.0  # the first window that cannot read the line
                if centre * rpm_unread / 60.0 >= freqs_hz[-1]:
                    raise BearingTwinError(f"the shaft speed ({rpm_unread:g} rpm) puts its order {centre:.2f} line "
                                           f"beyond the envelope spectrum of a window ({freqs_hz[-1]:g} Hz): check the "
                                           "speed, or give the extractor fewer features.harmonics")
                bin_orders = (freqs_hz[1] - freqs_hz[0]) * 60.0 / rpm_unread
                raise BearingTwinError(f"at {rpm_unread:g} rpm a window resolves {bin_orders:.2f} shaft orders, too "
                                       f"coarse for the order {centre:.2f} line and its flanks: check the speed, or use "
                                       "longer windows or a wider features.floor_width_orders")
            floor = np.nanmedian(np.where(flanks, power, np.nan), axis=1)
            line = np.where(in_line, power, 0.0).sum(axis=1) / in_line.sum(axis=1)
            columns.append(np.log10(np.maximum(line, 1e-300) / np.maximum(floor, 1e-300)))
        if self.band_power:
            columns.append(np.log10(np.mean(in_band ** 2, axis=1) / np.var(X, axis=1)))
        return np.stack(columns, axis=1)

    def fit_transform(self, X, y=None, *, fs_hz: float, rpm) -> np.ndarray:
        return self.fit(X, y, fs_hz=fs_hz, rpm=rpm).transform(X, fs_hz=fs_hz, rpm=rpm)

    def get_feature_names_out(self, input_features=None) -> np.ndarray:
        """The columns' names (``feature_names_``), as scikit-learn's transformers give them."""
        if not hasattr(self, "feature_names_"):
            raise BearingTwinError("EnvelopeOrderFeatures: call fit before get_feature_names_out")
        return np.asarray(self.feature_names_, dtype=object)

    @staticmethod
    def _check(X, fs_hz: float, rpm) -> tuple[np.ndarray, np.ndarray]:
        """Windows as float64 (n, L) and each window's shaft rate in Hz."""
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 2 or X.shape[0] == 0 or X.shape[1] < 16:
            raise BearingTwinError(f"X must be (n_windows, window_length >= 16), got shape {X.shape}")
        if not np.all(np.isfinite(X)):
            raise BearingTwinError("X holds NaN or infinite values")
        if not (np.isfinite(fs_hz) and fs_hz > 0):
            raise BearingTwinError(f"fs_hz must be a positive sampling rate, got {fs_hz}")
        if rpm is None:
            raise BearingTwinError("rpm: envelope-order features need each window's shaft speed; this data source gives none")
        rpm = np.asarray(rpm, dtype=np.float64)
        if rpm.shape not in ((), (len(X),)):
            raise BearingTwinError(f"rpm must be one speed or one per window ({len(X)}), got shape {rpm.shape}")
        rpm = np.broadcast_to(rpm, (len(X),))
        if not np.all(np.isfinite(rpm) & (rpm > 0)):
            raise BearingTwinError("rpm must be positive and finite for every window")
        return X, rpm / 60.0
