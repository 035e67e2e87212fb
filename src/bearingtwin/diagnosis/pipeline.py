"""The product of a training run: everything needed to go from raw windows to a diagnosis.

A :class:`DiagnosisPipeline` is built by the training run from the very objects it fitted
(``models.experiment.run_experiment``): the window normalization the dataset applied, the
fitted feature extractor (with its VMD parameters) and the fitted classifier. Diagnosing a
window therefore runs the same code path as training did, never a copy of it.

It is saved as plain, inspectable files, nothing from the training data or the cache:

- ``pipeline.json``: window length, sampling rate, normalization, class names, bearing
  geometry, the extractor's parameters and fitted state, the classifier's kind, the config
  and its hash;
- ``network.pt`` (CNN-BiLSTM): the network's ``state_dict``, loadable on a CPU without a
  Lightning Trainer, beside the feature scaler's statistics in ``pipeline.json``;
- ``svm.json`` and ``svm.npz`` (SVM): the fitted scikit-learn objects' state, structure and
  arrays (:mod:`bearingtwin.models.persistence`);
- ``sklearn.skops`` (any other scikit-learn classifier, ``classifier=sklearn``): the fitted
  estimator in skops' format, read back trusting only the types of the packages it may hold.
"""

from __future__ import annotations

import copy
import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from bearingtwin.data.units import (INTEGRATED_QUANTITIES, acceleration_factor, acceleration_unit, quantity_of,
                                    same_unit, unit_key)
from bearingtwin.data.windows import normalize_windows
from bearingtwin.diagnosis.evidence import PhysicsFirst
from bearingtwin.errors import BearingTwinError
from bearingtwin.features.envelope_orders import EnvelopeOrderFeatures
from bearingtwin.features.extractor import EXTRACTORS
from bearingtwin.features.time_domain import FEATURE_NAMES
from bearingtwin.physics.geometry import FAULTS

FORMAT = 2  # bump when the saved layout changes
PLAIN_FORMAT = 1
"""The format a pipeline without ``physics_first`` is still saved in: the layout before that key, which an
earlier version reads as it always did; one with the key is saved as :data:`FORMAT`, which an earlier version
refuses rather than diagnose without the rule its scores were made with."""
LEVEL_FACTOR = 10.0
"""How far outside the training windows' levels a record may lie before a diagnosis says so."""
SPEED_MARGIN = 1.25
"""How far beyond the training windows' shaft speeds (a factor, above the fastest or below the slowest) a record's
speed may lie before a diagnosis says so: a plain margin over the speeds seen, not a value fitted to any result."""
RANGE_MARGIN = 0.25
"""How far beyond the training windows' range of a feature (a share of that range's width) a window's feature may lie
before a diagnosis says the classifier extrapolates: a plain margin over the values seen, not fitted to any result."""
PIPELINE_FILE = "pipeline.json"


@dataclass
class DiagnosisPipeline:
    """Fitted extractor + classifier, and the facts a recording must match to be diagnosed.

    Attributes:
        extractor: a fitted extractor of :data:`bearingtwin.features.extractor.EXTRACTORS`.
        classifier: a fitted :class:`CnnBiLstmClassifier`, :class:`SvmClassifier` or :class:`SklearnClassifier`;
            its ``classes_`` are :data:`FAULTS` indices.
        window_length: samples per window.
        fs_hz: sampling rate the model was trained at, Hz.
        window_normalization: ``none`` or ``zscore`` (:func:`normalize_windows`).
        bearing: the bearing config of the data (geometry: defect frequencies).
        config: the resolved training config; ``config_hash`` its hash.
        unit: the unit of the training windows (``m/s^2``, ``g``; "" when the data did not state one).
        window_level: the 5th and 95th percentiles of the training windows' standard deviation, in ``unit``:
            the levels the classifier has seen; None when the windows are normalized (any level is alike).
        speeds_rpm: the slowest and fastest shaft speed of the training windows, rev/min; None where the data stated
            none (or the model was saved before they were kept).
        physics_first: where the envelope spectrum leaves no doubt, it decides the window instead of the
            classifier (:class:`PhysicsFirst`); None: the classifier decides every window.
        training_records: path (from the folder the files share) -> SHA-256 of its contents, for every recorded
            file whose windows the classifier was trained on (none for simulated data): a diagnosis of such a file,
            under any name, is no test of the model.
        calibration_records: path (from the folder the files share) -> SHA-256 of its contents, for every record a
            twin-trained model's twin was calibrated on: a diagnosis of such a record, under any name (the Data
            Center's ``97.mat`` as much as ``normal_0_97.mat``), is no test of the model.
        feature_range: the smallest and the largest value of each feature over the training windows, in the
            classifier's column order: where a window's lie well beyond them (:meth:`features_unseen`) the classifier
            extrapolates, and its probabilities do not say so. None for the raw windows (their samples are no
            features; :attr:`window_level` holds their level) or a model saved before it was kept.
    """

    extractor: object
    classifier: object
    window_length: int
    fs_hz: float
    window_normalization: str = "none"
    bearing: dict = field(default_factory=dict)
    config: dict = field(default_factory=dict)
    config_hash: str = ""
    unit: str = ""
    window_level: tuple[float, float] | None = None
    speeds_rpm: tuple[float, float] | None = None
    physics_first: PhysicsFirst | None = None
    training_records: dict = field(default_factory=dict)
    feature_range: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    calibration_records: dict = field(default_factory=dict)

    @property
    def class_names(self) -> list[str]:
        """State names of the classifier's outputs, in its column order."""
        return [FAULTS[int(label)] for label in self.classifier.classes_]

    @property
    def reads_defect_orders(self) -> bool:
        """Whether the features read the envelope spectrum at the bearing's defect orders (the shaft speed and
        the recorded bearing matter to them)."""
        return isinstance(self.extractor, EnvelopeOrderFeatures)

    @property
    def scale_free(self) -> str | None:
        """Why the classifier's input does not change with the windows' scale (a unit's factor, a sensor's gain), in
        words; None where it does: the model then reads the windows' level as it learnt it (:attr:`window_level`)."""
        if self.window_normalization != "none":
            return "the model scales every window to one level"
        if isinstance(self.extractor, EnvelopeOrderFeatures):  # shares, prominences and band_power: power over power
            return "the model's features are ratios of one window's powers"
        return None

    @property
    def reads_spectrum_shape(self) -> str | None:
        """What of the model's input a record integrated once or twice more than its training records changes (a
        velocity's spectrum is an acceleration's with each line divided by its frequency), in words; None where nothing
        does. Said of a model free of scale (:attr:`scale_free`); one that reads the level is refused other quantities
        for that first."""
        extractor = self.extractor
        if not isinstance(extractor, EnvelopeOrderFeatures):
            return ("its features describe the waveform (its samples, or statistics of a VMD mode), whose shape "
                    "integration changes")
        low, high = (float(edge) * self.fs_hz / 2 for edge in extractor.band_nyquist)
        if extractor.band_power:
            return (f"its band_power feature is the share of a window's power in the band-pass ({low:g}-{high:g} Hz), "
                    "which integration lowers (it divides each line by its frequency, favouring the band below): the "
                    "record would read as a bearing that rings less")
        # Pre-whitened, every line's magnitude is one: what integration leaves is a phase shift of -90 degrees at
        # every frequency (a sign change, integrated twice), a Hilbert transform, which leaves the envelope as it was.
        if extractor.prewhiten == "cepstral":
            return None
        return (f"its defect lines are read in the envelope of the band-pass ({low:g}-{high:g} Hz), whose content "
                f"integration tilts ({high / low:.3g} times weaker at its top than at its bottom, once integrated)")

    @property
    def needs_rpm(self) -> bool:
        """Whether a diagnosis needs the shaft speed: for the features (:attr:`reads_defect_orders`) or for the
        physics that may decide a window (:attr:`physics_first`)."""
        return self.reads_defect_orders or self.physics_first is not None

    def check_can_diagnose(self) -> None:
        """Refuse a model whose features need the true label of the window they describe."""
        if getattr(self.extractor, "vmd_params", None) == "per_class":
            raise BearingTwinError(
                "this model was trained with features.vmd_params=per_class: each window is decomposed with its own "
                "label's VMD parameters, so it cannot diagnose an unlabeled window (retrain with features.vmd_params=global)"
            )

    def check_window_shape(self, windows: np.ndarray) -> None:
        """Refuse ``windows`` that are not one window of the model's length a row, naming the length it reads."""
        if windows.ndim != 2 or windows.shape[1] != self.window_length:
            given = f"windows of {windows.shape[1]} samples" if windows.ndim == 2 else f"an array of shape {windows.shape}"
            raise BearingTwinError(f"{given}: the model reads windows of {self.window_length} samples at {self.fs_hz:g} "
                                   "Hz, one a row; cut the record into such windows (bearingtwin-diagnose reads a whole "
                                   "record)")

    def features(self, windows, rpm=None, bearing: dict | None = None) -> np.ndarray:
        """The classifier's input for raw ``windows`` (n, window_length) at ``fs_hz``; ``rpm`` per window or one.

        ``bearing`` is the config of the bearing the windows were recorded on (None: the model's own).
        Features read at defect orders are read at that bearing's: an outer-race line is where the
        recorded bearing's outer race puts it, whatever bearing the model was trained on.
        """
        self.check_can_diagnose()
        windows = np.asarray(windows, dtype=np.float64)
        self.check_window_shape(windows)
        unreadable = np.flatnonzero(~np.isfinite(windows).all(axis=1))
        if unreadable.size:
            raise BearingTwinError(f"windows {_listed(unreadable)} (of {len(windows)}, counted from 0) hold NaN or "
                                   "infinite values")
        if self.needs_rpm and rpm is None:
            reason = ("this model's features are read on the shaft-order axis" if self.reads_defect_orders else
                      "this model's physics_first reads a window's defect lines at the shaft's speed")
            raise BearingTwinError(f"rpm: {reason}; give the shaft speed")
        windows = normalize_windows(windows, self.window_normalization)
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is refused below in one line, not warned of
            if self.reads_defect_orders:
                features = self._extractor_at(bearing).transform(windows, fs_hz=self.fs_hz, rpm=rpm)
            else:
                features = self.extractor.transform(windows)
        unreadable = np.flatnonzero(~np.isfinite(features).all(axis=1))
        if unreadable.size:
            largest = float(np.max(np.abs(windows[unreadable])))
            why = (f"values up to {largest:.3g} overflow them; give the record in a unit that keeps its values within "
                   "1e150" if largest > 1e150 else f"values up to {largest:.3g}")
            raise BearingTwinError(f"windows {_listed(unreadable)} (counted from 0): features not finite, {why}")
        return features

    @property
    def levels_seen(self) -> tuple[float, float] | None:
        """The training windows' 5-95 % range of levels (:attr:`window_level`) a diagnosis holds windows against; None
        where the model does not read the level (:attr:`scale_free`) or was saved before it kept its levels."""
        return None if self.scale_free else self.window_level

    def levels_unseen(self, levels) -> np.ndarray:
        """Whether each of ``levels`` (window standard deviations, in :attr:`unit`) stands more than
        :data:`LEVEL_FACTOR` outside the levels the model was trained on (:attr:`levels_seen`, which must be known):
        a unit or gain the model did not see, which every amplitude-dependent feature reads as another state."""
        low, high = self.levels_seen
        return (np.asarray(levels) < low / LEVEL_FACTOR) | (np.asarray(levels) > high * LEVEL_FACTOR)

    def level_note(self, windows: np.ndarray) -> str | None:
        """What to say when raw ``windows`` (n, window_length), a record's, stand a decade or more above or below the
        levels the model was trained on (:meth:`levels_unseen`, of their median level). None when they do not, or the
        model does not read the level."""
        if self.levels_seen is None:
            return None
        level = float(np.median(np.std(windows, axis=1)))
        if not self.levels_unseen(level):
            return None
        low, high = self.levels_seen
        unit = f" {self.unit}" if self.unit else ""
        side = "above" if level > high else "below"
        return (f"the record's level (median window standard deviation {level:.3g}{unit}) lies more than "
                f"{LEVEL_FACTOR:g} times {side} the 5-95 % range of the model's training windows ({low:.3g}-{high:.3g}"
                f"{unit}): check the record's unit and gain; the model reads amplitudes as it learnt them")

    def speed_note(self, rpm: float | None) -> str | None:
        """What to say when a record's shaft speed ``rpm`` (rev/min) lies more than :data:`SPEED_MARGIN` beyond the
        speeds the model was trained at (:attr:`speeds_rpm`): impacts, resonances and the noise floor stand otherwise
        at other speeds, so the model reads such a record as it never learnt. None when it does not, or either is
        unknown."""
        if self.speeds_rpm is None or rpm is None:
            return None
        low, high = self.speeds_rpm
        if low / SPEED_MARGIN <= rpm <= high * SPEED_MARGIN:
            return None
        side = f"above the fastest ({high:.0f})" if rpm > high else f"below the slowest ({low:.0f})"
        return (f"the shaft speed ({rpm:.0f} rev/min) lies more than {SPEED_MARGIN - 1:.0%} {side} of the model's "
                "training windows: the model reads a record at a speed it never learnt; hold its verdict against the "
                "physics evidence")

    @property
    def feature_names(self) -> list[str]:
        """The classifier's input columns by name (the nine time-domain statistics of a VMD mode, or the defect-order
        features an extractor names)."""
        return list(getattr(self.extractor, "feature_names_", FEATURE_NAMES))

    def features_unseen(self, features: np.ndarray) -> np.ndarray:
        """Per row of ``features`` (the classifier's input, as :meth:`features` gives it), the name of the feature
        lying farthest beyond the training windows' range (:attr:`feature_range`) by more than :data:`RANGE_MARGIN`
        of its width, "" where none does or the range is not known."""
        unseen = np.full(len(features), "", dtype=object)
        if self.feature_range is None:
            return unseen
        low, high = (np.asarray(edge, dtype=np.float64) for edge in self.feature_range)
        # A feature constant over the training windows: any other value lies beyond it; its width is one of the
        # value's own rounding errors rather than zero, for a quotient.
        width = np.maximum(high - low, 1e-9 * np.maximum(np.abs(high), 1.0))
        beyond = np.maximum(low - features, features - high) / width
        farthest = np.argmax(beyond, axis=1)
        outside = beyond[np.arange(len(features)), farthest] > RANGE_MARGIN
        unseen[outside] = np.asarray(self.feature_names, dtype=object)[farthest[outside]]
        return unseen

    def _extractor_at(self, bearing: dict | None):
        """The defect-order extractor reading ``bearing``'s orders (the model's own for None or the same bearing)."""
        if bearing and bearing != self.extractor.bearing:
            return copy.copy(self.extractor).set_params(bearing=bearing)
        return self.extractor

    def bands_on_shaft_harmonics(self, bearing: dict) -> list[str]:
        """The features that read a shaft harmonic at ``bearing``'s defect orders but not at the model's own
        (:meth:`EnvelopeOrderFeatures.bands_on_shaft_harmonics`): where the model may take the shaft's lines
        for a defect's. None for features that do not read defect orders."""
        if not self.reads_defect_orders:
            return []
        own = set(self.extractor.bands_on_shaft_harmonics())
        return [name for name in self._extractor_at(bearing).bands_on_shaft_harmonics() if name not in own]

    def predict_proba(self, windows, rpm=None, bearing: dict | None = None) -> np.ndarray:
        """(n, n_classes) probabilities, columns in :attr:`class_names` order."""
        return self.classifier.predict_proba(self.features(windows, rpm, bearing))

    def predict(self, windows, rpm=None, bearing: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Each window's state name and the classifier's probabilities (:meth:`decide`)."""
        decision = self.decide(windows, rpm, bearing)
        return decision.states, decision.probabilities

    def decide(self, windows, rpm=None, bearing: dict | None = None) -> "Decision":
        """Each window's state name, the classifier's probabilities, whether the physics decided the window
        (:attr:`physics_first`) rather than the classifier, and the feature it saw least (:meth:`features_unseen`)."""
        features = self.features(windows, rpm, bearing)
        labels, probabilities = self.classifier.predict_with_proba(features)
        labels, by_physics = self.overrule(labels, windows, rpm, bearing)
        return Decision(np.array([FAULTS[int(label)] for label in labels]), probabilities, by_physics,
                        self.features_unseen(features))

    def overrule(self, labels: np.ndarray, windows, rpm, bearing: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The classifier's ``labels`` (:data:`FAULTS` indices) of raw ``windows``, each window where the envelope
        spectrum leaves no doubt (:attr:`physics_first`) set to the physics' state, and the mask of those windows.
        The physics names only states the classifier knows."""
        labels = np.array(labels, copy=True)
        by_physics = np.zeros(len(labels), dtype=bool)
        if self.physics_first is None:
            return labels, by_physics
        known = {FAULTS[int(label)] for label in self.classifier.classes_}
        states = self.physics_first.states(windows, self.fs_hz, rpm, bearing or self.bearing)
        for index, state in enumerate(states):
            if state in known:
                labels[index], by_physics[index] = FAULTS.index(state), True
        return labels, by_physics

    # ------------------------------------------------------------ files

    def save(self, folder: str | Path) -> Path:
        """Write the pipeline into ``folder`` (created); returns ``folder``."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        meta = {
            "format": PLAIN_FORMAT if self.physics_first is None else FORMAT,
            "window_length": int(self.window_length),
            "fs_hz": float(self.fs_hz),
            "window_normalization": self.window_normalization,
            "class_names": self.class_names,
            "bearing": self.bearing,
            "config_hash": self.config_hash,
            "config": self.config,
            "unit": self.unit,
            "window_level": None if self.window_level is None else [float(v) for v in self.window_level],
            "speeds_rpm": None if self.speeds_rpm is None else [float(v) for v in self.speeds_rpm],
            "physics_first": None if self.physics_first is None else asdict(self.physics_first),
            "training_records": self.training_records,
            "calibration_records": self.calibration_records,
            "feature_range": None if self.feature_range is None else [[float(v) for v in edge]
                                                                      for edge in self.feature_range],
            "extractor": _extractor_state(self.extractor),
            "classifier": _save_classifier(self.classifier, folder),
        }
        (folder / PIPELINE_FILE).write_text(json.dumps(meta, indent=1, default=_jsonable))
        return folder

    @classmethod
    def load(cls, folder: str | Path) -> "DiagnosisPipeline":
        folder = Path(folder)
        try:
            meta = json.loads((folder / PIPELINE_FILE).read_text())
        except (OSError, ValueError) as error:
            raise BearingTwinError(f"{folder}: not a saved diagnosis pipeline ({error})") from None
        if meta.get("format") not in (PLAIN_FORMAT, FORMAT):
            raise BearingTwinError(f"{folder}: pipeline format {meta.get('format')}, this version reads {PLAIN_FORMAT} "
                                   f"and {FORMAT}")
        return cls(
            extractor=_extractor_from_state(meta["extractor"]),
            classifier=_load_classifier(meta["classifier"], folder),
            window_length=meta["window_length"],
            fs_hz=meta["fs_hz"],
            window_normalization=meta["window_normalization"],
            bearing=meta["bearing"],
            config=meta["config"],
            config_hash=meta["config_hash"],
            unit=meta.get("unit", ""),  # models saved before these were recorded: unit and levels unknown
            window_level=None if meta.get("window_level") is None else tuple(meta["window_level"]),
            speeds_rpm=None if meta.get("speeds_rpm") is None else tuple(meta["speeds_rpm"]),  # unknown: saved before
            physics_first=None if meta.get("physics_first") is None else PhysicsFirst(**meta["physics_first"]),
            training_records=meta.get("training_records", {}),  # models saved before they were recorded: none known
            feature_range=None if meta.get("feature_range") is None else tuple(map(tuple, meta["feature_range"])),
            calibration_records=meta.get("calibration_records", {}),  # saved before they were recorded: by name only
        )


@dataclass
class Decision:
    """What :meth:`DiagnosisPipeline.decide` says of each of n windows.

    Attributes:
        states: (n,) state names.
        probabilities: (n, n_classes) the classifier's, columns in :attr:`DiagnosisPipeline.class_names` order.
        by_physics: (n,) whether the envelope spectrum decided the window (:attr:`DiagnosisPipeline.physics_first`).
        unseen: (n,) the feature lying farthest beyond the training windows' range, "" where none does
            (:meth:`DiagnosisPipeline.features_unseen`).
    """

    states: np.ndarray
    probabilities: np.ndarray
    by_physics: np.ndarray
    unseen: np.ndarray


UNIT_CHECKS = ("as stated", "converted", "assumed", "not checked", "not needed")
"""How a record's unit was held against the model's (:attr:`PreparedRecord.unit_check`, :func:`in_model_unit`): the
model's own, converted to it, assumed to be it (the file states none), not checked (the model states none), not needed
(no unit's scale matters to the model: :attr:`DiagnosisPipeline.scale_free`)."""

_CONVERSION_NEEDS = {
    "a voltage": "give scale=<1 / the sensor's sensitivity> unit=<its acceleration unit> (a 100 mV/g sensor's volts: "
                 "scale=10 unit=g; its data sheet or calibration gives the sensitivity)",
    "a velocity": "a velocity is an integrated acceleration, so diagnose the accelerometer's own record, in an "
                  "acceleration unit",
    "a displacement": "a displacement is an acceleration integrated twice, so diagnose the accelerometer's own "
                      "record, in an acceleration unit",
}
"""What a record in a unit of another quantity takes to be read in an acceleration unit, in words."""


def unit_for_model(unit: str, pipeline: DiagnosisPipeline, source: str) -> tuple[float | None, list[str], str]:
    """How samples in ``unit`` (``source``'s, named in a refusal) are read by the model: the factor converting them to
    the unit it was trained in (None: read as they are), notes, and how the units were held against each other
    (:data:`UNIT_CHECKS`).

    A model that reads the windows' level converts them where both are acceleration units (g, mg, m/s^2, mm/s^2,
    ...), reads them as if in its own where none is stated or text no unit known here (said so), and refuses a
    voltage, a velocity or a displacement (no acceleration factor converts them); it reads them as they are when it
    states no unit. A model free of scale (:attr:`DiagnosisPipeline.scale_free`) reads any unit as it is, a voltage
    (an accelerometer's: its acceleration times a gain) too, but refuses a velocity or a displacement where its input
    reads the spectrum's shape (:attr:`DiagnosisPipeline.reads_spectrum_shape`), which integration tilts."""
    model_unit = pipeline.unit
    quantity = quantity_of(unit)
    if pipeline.scale_free:
        return _unit_for_scale_free(unit, quantity, pipeline, source)
    if not model_unit:  # trained on records that state none, or saved before models kept their unit
        return None, [], "not checked"
    if not unit:  # g and m/s^2 differ by 9.81: a level check that fires at a decade never sees it
        return None, [f"the file states no unit: read as if in {model_unit}, the unit the model was trained in "
                      "(where it is another, give unit=<unit>, or state it in the file: a CSV column header such as "
                      "'acc (m/s^2)', an .npz's 'unit' entry)"], "assumed"
    units = acceleration_unit(unit), acceleration_unit(model_unit)
    if same_unit(unit, model_unit):
        return None, [], "as stated"
    if units[0] is None and units[1] is not None and quantity not in _CONVERSION_NEEDS:
        # Text no unit known here (an .npz's unit entry "A"; a CSV header's brackets it does not know are no unit):
        # as good as none stated, and said so.
        return None, [f"the file states {unit!r}, no unit known here: read as if in {model_unit}, the unit the "
                      "model was trained in (where it is another, state it)"], "assumed"
    if None in units:
        other, into = (unit, model_unit) if units[0] is None else (model_unit, unit)
        needs = (_CONVERSION_NEEDS.get(quantity, "convert it to an acceleration unit (g, m/s^2, mg, mm/s^2) and "
                                                 "state that unit") if units[1] is not None else
                 f"give the record in {model_unit}, as the model's training records were")
        raise BearingTwinError(f"{source}: the record is in {unit}, the model was trained on windows in "
                               f"{model_unit} and reads their level, and {other} "
                               f"({quantity_of(other) or 'a unit not known here'}) is not converted into {into} here: "
                               f"{needs}")
    factor = acceleration_factor(*units)
    return factor, [f"converted from {units[0]} to {units[1]}, the unit the model was trained in (x {factor:.6g})"], \
        "converted"


def _unit_for_scale_free(unit: str, quantity: str | None, pipeline: DiagnosisPipeline,
                         source: str) -> tuple[None, list[str], str]:
    """:func:`unit_for_model` for a model no unit's scale matters to: the samples as they are, or refused where they
    are a velocity's or a displacement's and the model reads the spectrum's shape."""
    if not unit or quantity == "an acceleration" or unit_key(unit) == unit_key(pipeline.unit):
        return None, [], "not needed"
    free = pipeline.scale_free
    shape = pipeline.reads_spectrum_shape
    if quantity in INTEGRATED_QUANTITIES and shape:
        raise BearingTwinError(f"{source}: the record is in {unit} ({quantity}): {free}, but {shape}; "
                               f"{_CONVERSION_NEEDS[quantity]}")
    if quantity in INTEGRATED_QUANTITIES:
        return None, [f"the record is in {unit} ({quantity}), not an acceleration: read as it is ({free}, and its "
                      "features do not read the spectrum's shape, which integration tilts)"], "not needed"
    if quantity == "a voltage":
        return None, [f"the record is in {unit} (a voltage): read as it is, as an accelerometer's (its acceleration "
                      f"times the sensor's sensitivity, a gain, and {free}); a velocity sensor's volts would read as "
                      "another state"], "not needed"
    described = f"{unit!r}, no unit known here" if quantity is None else f"{unit} ({quantity}), not an acceleration"
    return None, [f"the file states {described}: read as it is ({free})"], "not needed"


def _jsonable(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serializable")


def _extractor_state(extractor) -> dict:
    """Kind, constructor parameters and fitted attributes (scikit-learn's trailing ``_``)."""
    kind = next(name for name, cls in EXTRACTORS.items() if type(extractor) is cls)
    fitted = {name: value for name, value in vars(extractor).items() if name.endswith("_") and not name.startswith("_")}
    return {"kind": kind, "params": extractor.get_params(), "fitted": fitted}


def _extractor_from_state(state: dict):
    params = dict(state["params"])
    if "progress" in params:  # a diagnosis shows its own progress, over records
        params["progress"] = False
    extractor = EXTRACTORS[state["kind"]](**params)
    for name, value in state["fitted"].items():
        setattr(extractor, name, value)
    return extractor


# The classifiers' modules are imported where they are needed: the network's pulls in Lightning,
# which a diagnosis with an SVM model (or a model server starting up) need not wait for.
def _save_classifier(classifier, folder: Path) -> dict:
    from bearingtwin.models.sklearn_classifier import SklearnClassifier
    from bearingtwin.models.svm import SvmClassifier

    if isinstance(classifier, SvmClassifier):  # before the network's module is imported: an SVM run need not
        from bearingtwin.models.persistence import save_estimator

        return {"kind": "svm", "files": save_estimator(classifier, folder / "svm")}
    if isinstance(classifier, SklearnClassifier):
        return {"kind": "sklearn", **classifier.save(folder)}
    from bearingtwin.models.cnn_bilstm import CnnBiLstmClassifier

    if isinstance(classifier, CnnBiLstmClassifier):
        return {"kind": "cnn_bilstm", **classifier.save(folder / "network.pt")}
    raise BearingTwinError(f"cannot save a {type(classifier).__name__} as a diagnosis model")


def _load_classifier(state: dict, folder: Path):
    if state["kind"] == "cnn_bilstm":
        from bearingtwin.models.cnn_bilstm import CnnBiLstmClassifier

        return CnnBiLstmClassifier.load(folder / "network.pt", state)
    if state["kind"] == "sklearn":
        from bearingtwin.models.sklearn_classifier import SklearnClassifier

        return SklearnClassifier.load(folder, state)
    if "files" not in state:  # an earlier version's svm.skops
        raise BearingTwinError(f"{folder}: the SVM was saved in skops' format by an earlier version of bearingtwin; "
                               "train the model again to diagnose with it")
    from bearingtwin.models.persistence import load_estimator

    return load_estimator(folder / "svm")


def _listed(indices: np.ndarray, shown: int = 5) -> str:
    """The first ``shown`` window indices, and "..." for the rest."""
    return ", ".join(map(str, indices[:shown])) + (", ..." if indices.size > shown else "")
