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
  arrays (:mod:`bearingtwin.models.persistence`).
"""

from __future__ import annotations

import copy
import json
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from bearingtwin.data.units import acceleration_factor, acceleration_unit, quantity_of, unit_key
from bearingtwin.data.windows import normalize_windows
from bearingtwin.diagnosis.evidence import PhysicsFirst
from bearingtwin.errors import BearingTwinError
from bearingtwin.features.envelope_orders import EnvelopeOrderFeatures
from bearingtwin.features.extractor import EXTRACTORS
from bearingtwin.physics.geometry import FAULTS

FORMAT = 2  # bump when the saved layout changes
PLAIN_FORMAT = 1
"""The format a pipeline without ``physics_first`` is still saved in: the layout before that key, which an
earlier version reads as it always did; one with the key is saved as :data:`FORMAT`, which an earlier version
refuses rather than diagnose without the rule its scores were made with."""
LEVEL_FACTOR = 10.0
"""How far outside the training windows' levels a record may lie before a diagnosis says so."""
PIPELINE_FILE = "pipeline.json"


@dataclass
class DiagnosisPipeline:
    """Fitted extractor + classifier, and the facts a recording must match to be diagnosed.

    Attributes:
        extractor: a fitted extractor of :data:`bearingtwin.features.extractor.EXTRACTORS`.
        classifier: a fitted :class:`CnnBiLstmClassifier` or :class:`SvmClassifier`; its
            ``classes_`` are :data:`FAULTS` indices.
        window_length: samples per window.
        fs_hz: sampling rate the model was trained at, Hz.
        window_normalization: ``none`` or ``zscore`` (:func:`normalize_windows`).
        bearing: the bearing config of the data (geometry: defect frequencies).
        config: the resolved training config; ``config_hash`` its hash.
        unit: the unit of the training windows (``m/s^2``, ``g``; "" when the data did not state one).
        window_level: the 5th and 95th percentiles of the training windows' standard deviation, in ``unit``:
            the levels the classifier has seen; None when the windows are normalized (any level is alike).
        physics_first: where the envelope spectrum leaves no doubt, it decides the window instead of the
            classifier (:class:`PhysicsFirst`); None: the classifier decides every window.
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
    physics_first: PhysicsFirst | None = None

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

    def features(self, windows, rpm=None, bearing: dict | None = None) -> np.ndarray:
        """The classifier's input for raw ``windows`` (n, window_length) at ``fs_hz``; ``rpm`` per window or one.

        ``bearing`` is the config of the bearing the windows were recorded on (None: the model's own).
        Features read at defect orders are read at that bearing's: an outer-race line is where the
        recorded bearing's outer race puts it, whatever bearing the model was trained on.
        """
        self.check_can_diagnose()
        windows = np.asarray(windows, dtype=np.float64)
        if windows.ndim != 2 or windows.shape[1] != self.window_length:
            raise BearingTwinError(f"windows must have shape (n, {self.window_length}), got {windows.shape}")
        unreadable = np.flatnonzero(~np.isfinite(windows).all(axis=1))
        if unreadable.size:
            raise BearingTwinError(f"windows {_listed(unreadable)} (of {len(windows)}, counted from 0) hold NaN or "
                                   "infinite values")
        if self.needs_rpm and rpm is None:
            reason = ("this model's features are read on the shaft-order axis" if self.reads_defect_orders else
                      "this model's physics_first reads a window's defect lines at the shaft's speed")
            raise BearingTwinError(f"rpm: {reason}; give the shaft speed")
        windows = normalize_windows(windows, self.window_normalization)
        if self.reads_defect_orders:
            features = self._extractor_at(bearing).transform(windows, fs_hz=self.fs_hz, rpm=rpm)
        else:
            features = self.extractor.transform(windows)
        overflowed = np.flatnonzero(~np.isfinite(features).all(axis=1))
        if overflowed.size:  # values so large that powers of them overflow (1e154 and above)
            raise BearingTwinError(f"windows {_listed(overflowed)} "
                                   f"(counted from 0): features not finite, values up to {np.max(np.abs(windows)):.3g} "
                                   "overflow them; give the record in a unit that keeps its values within 1e150")
        return features

    def level_note(self, windows: np.ndarray) -> str | None:
        """What to say when raw ``windows`` (n, window_length) stand a decade or more above or below the levels the
        model was trained on (:attr:`window_level`): a unit or gain the model did not see, which every
        amplitude-dependent feature reads as another state. None when they do not, or the model normalizes."""
        if self.window_level is None:
            return None
        level = float(np.median(np.std(windows, axis=1)))
        low, high = self.window_level
        if low / LEVEL_FACTOR <= level <= high * LEVEL_FACTOR:
            return None
        unit = f" {self.unit}" if self.unit else ""
        side = "above" if level > high else "below"
        return (f"the record's level (median window standard deviation {level:.3g}{unit}) lies more than "
                f"{LEVEL_FACTOR:g} times {side} the 5-95 % range of the model's training windows ({low:.3g}-{high:.3g}"
                f"{unit}): check the record's unit and gain; the model reads amplitudes as it learnt them")

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
        states, probabilities, _ = self.decide(windows, rpm, bearing)
        return states, probabilities

    def decide(self, windows, rpm=None, bearing: dict | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each window's state name, the classifier's probabilities, and whether the physics decided the window
        (:attr:`physics_first`) rather than the classifier."""
        labels, probabilities = self.classifier.predict_with_proba(self.features(windows, rpm, bearing))
        labels, by_physics = self.overrule(labels, windows, rpm, bearing)
        return np.array([FAULTS[int(label)] for label in labels]), probabilities, by_physics

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
            "physics_first": None if self.physics_first is None else asdict(self.physics_first),
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
            physics_first=None if meta.get("physics_first") is None else PhysicsFirst(**meta["physics_first"]),
        )


UNIT_CHECKS = ("as stated", "converted", "assumed", "not checked", "not needed")
"""How a record's unit was held against the model's (:attr:`PreparedRecord.unit_check`, :func:`in_model_unit`): the
model's own, converted to it, assumed to be it (the file states none), not checked (the model states none), not needed
(the model normalizes every window, so no unit's scale matters to it)."""

_CONVERSION_NEEDS = {
    "a voltage": "divide it by the sensor's sensitivity (V per g, from its data sheet or calibration) and state the "
                 "unit that gives (an .npz's 'unit' entry, a CSV header such as 'acc (g)')",
    "a velocity": "a velocity is an integrated acceleration, so diagnose the accelerometer's own record, in an "
                  "acceleration unit",
    "a displacement": "a displacement is an acceleration integrated twice, so diagnose the accelerometer's own "
                      "record, in an acceleration unit",
}
"""What a record in a unit of another quantity takes to be read in an acceleration unit, in words."""


def unit_for_model(unit: str, pipeline: DiagnosisPipeline, source: str) -> tuple[float | None, list[str], str]:
    """How samples in ``unit`` (``source``'s, named in a refusal) are read by the model: the factor converting them to
    the unit it was trained in (None: read as they are), notes, and how the units were held against each other
    (:data:`UNIT_CHECKS`). Converted where both are acceleration units (g, mg, m/s^2, mm/s^2, ...), read as if in the
    model's where none is stated or text no unit known here (said so), refused where the samples are a voltage, a
    velocity or a displacement (no acceleration factor converts them) and the model reads the windows' level. As they
    are when the model states no unit, and when it normalizes its windows (any unit's scale is alike to it), said so
    for a unit of another quantity than acceleration."""
    model_unit = pipeline.unit
    quantity = quantity_of(unit)
    if pipeline.window_normalization != "none":
        if not unit or quantity == "an acceleration":
            return None, [], "not needed"
        note = (f"the record is in {unit} ({quantity or 'a unit not known here'}), not an acceleration: read as it is, "
                "the model scaling every window to one level")
        if quantity in ("a velocity", "a displacement"):  # unlike a gain, integration changes the spectrum's shape
            note += (f"; {quantity}'s spectrum falls off towards high frequencies against an acceleration's: hold the "
                     "verdict against the physics evidence")
        return None, [note], "not needed"
    if not model_unit:  # trained on records that state none, or saved before models kept their unit
        return None, [], "not checked"
    if not unit:  # g and m/s^2 differ by 9.81: a level check that fires at a decade never sees it
        return None, [f"the file states no unit: read as if in {model_unit}, the unit the model was trained in "
                      "(where it is another, state it: a CSV column header such as 'acc (m/s^2)', an .npz's "
                      "'unit' entry)"], "assumed"
    units = acceleration_unit(unit), acceleration_unit(model_unit)
    if unit_key(unit) == unit_key(model_unit) or units[0] is not None and units[0] == units[1]:
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
