"""One training run, without tracking: data -> split -> features -> classifier -> scores.

Kept free of MLflow and Hydra so that the training entry point, ``bearingtwin-report
repeat`` and the tests run exactly the same code from a composed config.
"""

from __future__ import annotations

import os
import random
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from omegaconf import DictConfig
from sklearn.base import clone
from sklearn.metrics import confusion_matrix, precision_recall_fscore_support

from bearingtwin.checks import check_seed
from bearingtwin.config import bearing_config, plain_config
from bearingtwin.data.build import build_dataset
from bearingtwin.data.windows import split_indices
from bearingtwin.diagnosis.evidence import PhysicsFirst
from bearingtwin.diagnosis.pipeline import DiagnosisPipeline
from bearingtwin.errors import BearingTwinError
from bearingtwin.features.cache import cache_path, extract_features
from bearingtwin.features.envelope_orders import EnvelopeOrderFeatures
from bearingtwin.features.extractor import RawFeatures, build_feature_extractor
from bearingtwin.models.build import build_classifier
from bearingtwin.models.classes import training_classes
from bearingtwin.storage import file_digest
from bearingtwin.tracking.lifecycle import signals_kept

# Metrics that measure this machine, not the model: excluded when runs are compared for equality.
TIMING_METRICS = ("inference_ms_per_sample",)

CALIBRATION_RECALL_WARNING = 0.5
"""A calibration record whose windows are called its own state less often than this is misread (:func:`misread_calibration`)."""


def misread_calibration(metrics: dict) -> list[str]:
    """The states whose calibration records (a twin-to-real run's: the records the twin was calibrated on) the
    model calls their own state in under :data:`CALIBRATION_RECALL_WARNING` of the windows: a model that misreads
    the very records its twin was made from misreads the rig's others too."""
    return [key.removeprefix("calibration_recall_") for key, value in metrics.items()
            if key.startswith("calibration_recall_") and value < CALIBRATION_RECALL_WARNING]


@dataclass
class ExperimentResult:
    """Scores and by-products of one run, ready to be logged.

    ``metrics`` holds ``accuracy`` and ``precision_/recall_/f1_<class>`` (Table 3's form)
    as fractions; ``calibration_accuracy`` and ``calibration_recall_<class>`` on the dataset's
    validation windows if it has any (the calibration records of a twin-to-real run); and
    ``inference_ms_per_sample``.
    ``confusion`` is counts with true classes as rows; ``history`` the per-epoch training curves (empty for the SVM);
    ``vmd_params`` the VMD parameters the features used (Table 2's form); ``per_record``
    one row per test record (``record``, ``class``, ``windows``, ``accuracy``): which file fails.
    ``pipeline`` is the fitted extractor and classifier with what a diagnosis needs (the run's model);
    ``example_windows`` two test windows (and their shaft speed) as the model's input example. ``device`` is where
    the network trained (``cpu``, ``cuda``: ``trainer.accelerator=auto`` takes a GPU where there is one, and its
    arithmetic ends elsewhere than the CPU's); empty for other classifiers.
    """

    metrics: dict[str, float]
    confusion: np.ndarray
    class_names: tuple[str, ...]
    history: list[dict] = field(default_factory=list)
    vmd_params: list[dict] = field(default_factory=list)
    dataset_key: str = ""
    features_key: str = ""
    n_train: int = 0
    n_test: int = 0
    per_record: list[dict] = field(default_factory=list)
    pipeline: DiagnosisPipeline | None = None
    example_windows: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    device: str = ""
    example_rpm: float | None = None


def per_record_accuracy(dataset, test: np.ndarray, predicted: np.ndarray) -> list[dict]:
    """Accuracy of the test windows of each record, in record order."""
    rows = []
    for record_id in np.unique(dataset.record_ids[test]):
        of_record = dataset.record_ids[test] == record_id
        true = dataset.labels[test][of_record]
        rows.append({"record": Path(dataset.records[record_id]).name, "class": dataset.class_names[true[0]],
                     "windows": int(of_record.sum()), "accuracy": float(np.mean(predicted[of_record] == true))})
    return rows


def classification_scores(y_true, y_pred, class_names) -> tuple[dict[str, float], np.ndarray]:
    """Accuracy, per-class precision / recall / F1 and the confusion matrix over all ``class_names``.

    A class with test windows that is never predicted gets precision 0 (not NaN) so means over
    seeds stay defined. A class with no test windows (the healthy class of a test on fault records
    only) has no recall or F1, and is given none: a 0 there would read as a class the model fails;
    its precision is kept when the model called some window so (0: every such call was wrong).
    """
    labels = np.arange(len(class_names))
    precision, recall, f1, support = precision_recall_fscore_support(y_true, y_pred, labels=labels, zero_division=0)
    called = np.bincount(np.asarray(y_pred, dtype=int), minlength=len(class_names))
    scores = {"accuracy": float(np.mean(np.asarray(y_true) == np.asarray(y_pred)))}
    for label, name in enumerate(class_names):
        if support[label] or called[label]:
            scores[f"precision_{name}"] = float(precision[label])
        if support[label]:
            scores[f"recall_{name}"] = float(recall[label])
            scores[f"f1_{name}"] = float(f1[label])
    return scores, confusion_matrix(y_true, y_pred, labels=labels)


def curves_named_for_the_test_windows(history: list[dict]) -> list[dict]:
    """The network's per-epoch curves with its eval set's (``val_*``) named for what they are here, ``test_*``:
    the run's test windows. They never stop training or choose a model (the paper trains a fixed number of
    epochs), but an epoch count or a size read off them is chosen on the test windows."""
    return [{(f"test_{key[4:]}" if key.startswith("val_") else key): value for key, value in record.items()}
            for record in history]


def inference_ms_per_sample(classifier, X: np.ndarray, n_samples: int = 32) -> float:
    """Median wall time in ms to classify one sample on its own (batch of one), as a deployed
    diagnosis would; the median over ``n_samples`` samples resists scheduler hiccups.

    The network predicts on one torch thread (:func:`~bearingtwin.models.cnn_bilstm.one_torch_thread`): for a
    batch of one, extra threads only add synchronisation, and on a busy machine two threads contending for
    cores measured 220-290 ms against 1.1 ms on one thread for the same network.
    """
    times = []
    for row in X[:n_samples]:
        start = time.perf_counter()
        classifier.predict(row[None, :])
        times.append(time.perf_counter() - start)
    return 1e3 * float(np.median(times))


def seed_everything(seed: int) -> None:
    """``lightning.seed_everything(seed, workers=True)`` without importing Lightning: Python's and NumPy's
    generators, torch's if torch is loaded, and the environment variables Lightning reads. The network
    seeds all of them again when it is fitted (models/cnn_bilstm.py). Lightning and torch are imported
    only by a run that trains the network: an SVM run, a sweep's driver and a refused command start
    seconds sooner."""
    os.environ["PL_GLOBAL_SEED"] = str(seed)
    random.seed(seed)
    np.random.seed(seed)
    if "torch" in sys.modules:
        sys.modules["torch"].manual_seed(seed)
    os.environ["PL_SEED_WORKERS"] = "1"


def checked_settings(cfg: DictConfig, root_dir: str | None = None) -> tuple[object, list[FeatureGroup]]:
    """The seeded, unfitted classifier and the feature groups ``cfg`` describes, every setting of the seed, the
    classifier and the features checked before any data is built: a bad value raises, naming its key.
    ``root_dir`` is where Lightning may write."""
    seed = check_seed(cfg.seed)
    seed_everything(seed)
    classifier = build_classifier(cfg.classifier, cfg.trainer, seed=seed, root_dir=root_dir)
    # The cached extraction builds its own extractor; this one checks the features' settings, and a choice among
    # feature groups with nothing to choose.
    groups = chosen_feature_groups(cfg, build_feature_extractor(cfg.features))
    check_feature_bearing(cfg)
    physics_first_from(cfg)
    return classifier, groups


def physics_first_from(cfg: DictConfig) -> PhysicsFirst | None:
    """The ``physics_first`` setting as the pipeline carries it (None: the classifier decides every window)."""
    settings = cfg.get("physics_first")
    if settings is None:
        return None
    if not isinstance(settings, DictConfig):
        raise BearingTwinError(f"physics_first must be null or {{threshold_db: <dB>, margin_db: <dB>}}, got {settings!r}")
    unknown = sorted(set(settings) - {"threshold_db", "margin_db"})
    if unknown:
        raise BearingTwinError(f"physics_first.{unknown[0]} is not a setting; physics_first takes threshold_db and margin_db")
    missing = sorted({"threshold_db", "margin_db"} - set(settings))
    if missing:  # both written out, so that a run logs (and hashes) the rule it applied
        raise BearingTwinError(f"physics_first.{missing[0]} is missing; give both threshold_db and margin_db")
    return PhysicsFirst(**settings)


def run_experiment(cfg: DictConfig, root_dir: str | None = None) -> ExperimentResult:
    """Train and score the classifier the composed config describes.

    Features are extracted for all windows by the cached extractor, fitted on the training
    windows only; scores are on the test windows.

    ``cfg.seed`` fixes the split, weight initialisation, batch order and dropout;
    feature extraction is seeded by ``cfg.features.seed``, so seeds whose training windows are
    the same (a ``block`` or fixed split, or features fitted on no training set) share one cached
    extraction; under a ``random`` or ``record`` split each seed's training windows, hence its extraction, differ.
    ``root_dir`` is where Lightning may write (the Hydra run dir).
    """
    seed = cfg.seed
    classifier, groups = checked_settings(cfg, root_dir)
    physics_first = physics_first_from(cfg)
    dataset = build_dataset(cfg)
    check_feature_bearing(cfg, dataset.bearing)  # the bearing the records named, where no setting gave one
    if physics_first is not None and dataset.window_rpms is None:  # before the features' minutes
        raise BearingTwinError("physics_first reads each window at its shaft speed; this data states none")
    if dataset.fixed_split is not None:
        train, test = dataset.fixed_split
    else:
        train, test = split_indices(
            dataset.labels,
            dataset.record_ids,
            dataset.starts,
            dataset.record_lengths,
            dataset.windows.shape[1],
            method=cfg.data.split,
            train_fraction=cfg.data.train_fraction,
            seed=seed,
            class_names=dataset.class_names,
            records=dataset.records,
        )
    training_classes(dataset.labels[train])  # the classifier refuses one state too, but after the features' minutes
    features, vmd_params, extractor = extract_features(cfg.features, dataset, train, cfg.paths.cache_dir)
    y = dataset.labels

    def fit(model, X: np.ndarray):
        with signals_kept():  # Lightning turns an interrupt into exit(1)
            if cfg.classifier.name == "cnn_bilstm":  # the network records per-epoch curves on these windows
                return model.fit(X[train], y[train], eval_set=(X[test], y[test]))
            return model.fit(X[train], y[train])

    fit(classifier, features)
    choice = {}
    for group in groups:
        classifier, features, extractor, scores = choose_feature_group(
            group, classifier, features, extractor, dataset, train, fit,
            lambda: build_classifier(cfg.classifier, cfg.trainer, seed=seed, root_dir=root_dir))
        choice.update(scores)
    pipeline = DiagnosisPipeline(
        extractor=extractor,
        classifier=classifier,
        window_length=dataset.windows.shape[1],
        fs_hz=dataset.fs,
        window_normalization=dataset.window_normalization,
        bearing=data_bearing(cfg, dataset.bearing),
        config=plain_config(cfg),
        unit=dataset.unit,
        window_level=training_window_level(dataset, train),
        speeds_rpm=training_speeds(dataset, train),
        physics_first=physics_first,
        training_records=training_records(dataset, train),
        calibration_records=calibration_record_digests(cfg.data),
        feature_range=None if isinstance(extractor, RawFeatures) else (tuple(features[train].min(axis=0)),
                                                                       tuple(features[train].max(axis=0))),
    )

    def decided(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The model's labels of windows ``rows`` as a diagnosis decides them, which the physics decided, and the
        classifier's own labels."""
        labels = classifier.predict(features[rows])
        rpms = None if dataset.window_rpms is None else dataset.window_rpms[rows]
        return *pipeline.overrule(labels, dataset.windows[rows], rpms), labels

    predicted, by_physics, own = decided(test)
    scores, confusion = classification_scores(y[test], predicted, dataset.class_names)
    scores.update(choice)
    if physics_first is not None:  # how much of the accuracy is the classifier's: a rule deciding the easy windows
        scores["physics_decided"] = float(np.mean(by_physics))  # leaves it the hard ones, or only one state's
        scores["classifier_accuracy"] = float(np.mean(own == y[test]))  # alone, on every test window
        if not by_physics.all():
            scores["classifier_accuracy_left"] = float(np.mean(own[~by_physics] == y[test][~by_physics]))
    if len(dataset.validation):  # accuracy, and recall of the classes present
        y_val = y[dataset.validation]
        validation, _ = classification_scores(y_val, decided(dataset.validation)[0], dataset.class_names)
        scores.update({f"calibration_{name}": value for name, value in validation.items()
                       if name == "accuracy" or name.startswith("recall_")})
    scores["inference_ms_per_sample"] = inference_ms_per_sample(classifier, features[test])
    return ExperimentResult(
        metrics=scores,
        confusion=confusion,
        class_names=tuple(dataset.class_names),
        history=curves_named_for_the_test_windows(getattr(classifier, "history_", [])),
        device=getattr(classifier, "device_", ""),
        vmd_params=vmd_params,
        dataset_key=dataset.key,
        features_key=cache_path(cfg.features, dataset, train, cfg.paths.cache_dir).name,
        n_train=len(train),
        n_test=len(test),
        per_record=per_record_accuracy(dataset, test, predicted),
        example_windows=dataset.windows[test[:2]],
        example_rpm=None if dataset.window_rpms is None else float(dataset.window_rpms[test[0]]),
        pipeline=pipeline,
    )


def training_window_level(dataset, train: np.ndarray) -> tuple[float, float] | None:
    """The 5th and 95th percentiles of the training windows' standard deviation (None for normalized windows)."""
    if dataset.window_normalization != "none":
        return None
    low, high = np.percentile(np.std(dataset.windows[train], axis=1), [5, 95])
    return float(low), float(high)


def training_speeds(dataset, train: np.ndarray) -> tuple[float, float] | None:
    """The slowest and fastest shaft speed of the training windows ``train``, rev/min (None where none is known)."""
    if dataset.window_rpms is None:
        return None
    rpms = np.asarray(dataset.window_rpms[train], dtype=float)
    rpms = rpms[np.isfinite(rpms)]
    return (float(rpms.min()), float(rpms.max())) if rpms.size else None


def training_records(dataset, train: np.ndarray) -> dict[str, str]:
    """Path (from the folder the files share) -> SHA-256 of every recorded file the training windows ``train`` come
    from (a simulated record, known by its simulator key, has none): what a diagnosis needs to say that a record
    taught the model. The digests decide; the paths tell a reader which files they were."""
    return _digests({path for record in np.unique(dataset.record_ids[train])
                     if (path := Path(dataset.records[record]).resolve()).is_file()})


def _digests(paths) -> dict[str, str]:
    """Path (from the folder ``paths`` share) -> SHA-256 of its contents: two files of one name in two folders apart."""
    paths = sorted(paths)
    shared = Path(os.path.commonpath(paths)) if len(paths) > 1 else None
    return {(path.relative_to(shared).as_posix() if shared else path.name): file_digest(path) for path in paths}


def calibration_record_digests(data_cfg) -> dict[str, str]:
    """Path (from the folder they share) -> SHA-256 of each record a twin-trained model's twin was calibrated on (none
    for other data): what a diagnosis needs to know such a record under any name."""
    if data_cfg.get("source") != "twin_to_real":
        return {}
    from bearingtwin.data.twin_to_real import check_protocol

    return _digests({Path(path).resolve() for path in check_protocol(data_cfg)[0]})


@dataclass(frozen=True)
class FeatureGroup:
    """Envelope-order features a twin-trained protocol keeps only where the calibration records bear them out:
    the config key that asks for the choice, the extractor's settings without them (their columns are those
    the extractor so set no longer gives), what the extractor must have for there to be a choice, and the
    run's metric names."""

    key: str
    words: str
    pronoun: str
    dropped: Callable[[EnvelopeOrderFeatures], dict]
    present: Callable[[EnvelopeOrderFeatures], bool]
    needs: str
    kept_metric: str
    with_metric: str
    without_metric: str

    def check(self, extractor, calibration_windows: bool) -> None:
        """Refuse a choice with nothing to choose: no such features, or no calibration windows."""
        if not (isinstance(extractor, EnvelopeOrderFeatures) and self.present(extractor)):
            raise BearingTwinError(f"{self.key}: the features have no {self.words} to keep or drop ({self.needs})")
        if not calibration_windows:
            raise BearingTwinError(f"{self.key}: no calibration windows to choose on; set data=twin_to_real with "
                                   "data.calibration.validation_windows_per_record > 0")


FEATURE_GROUPS = (
    FeatureGroup("band_power_by_calibration", "band power", "it", lambda extractor: {"band_power": False},
                 lambda extractor: extractor.band_power,
                 "features=envelope_prominence or envelope_orders with features.band_power=true",
                 "band_power_kept", "band_power_calibration_accuracy", "lines_only_calibration_accuracy"),
    FeatureGroup("cage_lines_by_calibration", "cage-rate lines", "them",
                 lambda extractor: {"rates": [rate for rate in extractor.rate_names() if rate != "ftf"]},
                 lambda extractor: "ftf" in extractor.rate_names() and len(extractor.rate_names()) > 1,
                 "features=envelope_prominence or envelope_orders with ftf among features.rates, beside another rate",
                 "cage_lines_kept", "cage_lines_calibration_accuracy", "without_cage_lines_calibration_accuracy"),
)
"""In the order they are chosen: each choice is made on the features the ones before it left."""


def chosen_feature_groups(cfg: DictConfig, extractor) -> list[FeatureGroup]:
    """The groups the config asks to choose by the calibration records, ``extractor`` the features' (as built
    from ``cfg.features``); each refused where it has nothing to choose, before any data is built."""
    groups = [group for group in FEATURE_GROUPS if cfg.get(group.key)]
    calibrated = cfg.data.get("source") == "twin_to_real" and bool(cfg.data.calibration.get("validation_windows_per_record"))
    for group in groups:
        group.check(extractor, calibrated)
    return groups


def choose_feature_group(group: FeatureGroup, classifier, features: np.ndarray, extractor, dataset, train: np.ndarray,
                         fit, new_classifier):
    """The classifier, features and extractor with ``group``'s columns, or without them if that scores better on
    the calibration records' windows (``dataset.validation``; ties keep them), and the scores (``group``'s
    metrics: both accuracies and whether the group was kept, 1 or 0).

    ``classifier`` is fitted on ``features`` (``extractor``'s columns); ``fit(model, X)`` fits another on ``X``'s
    training rows.
    """
    group.check(extractor, len(dataset.validation) > 0)
    validation = dataset.validation
    # The extractor learns nothing from the windows (its band in Hz and its feature names): fitted on one.
    first = train[:1]
    reduced = clone(extractor).set_params(**group.dropped(extractor)).fit(
        dataset.windows[first], fs_hz=dataset.fs, rpm=dataset.window_rpms[first])
    rest = np.array([name in reduced.feature_names_ for name in extractor.feature_names_])
    without = fit(new_classifier(), features[:, rest])
    y_val = dataset.labels[validation]
    accuracy = {"with": float(np.mean(classifier.predict(features[validation]) == y_val)),
                "without": float(np.mean(without.predict(features[validation][:, rest]) == y_val))}
    scores = {group.with_metric: accuracy["with"], group.without_metric: accuracy["without"],
              group.kept_metric: float(accuracy["with"] >= accuracy["without"])}
    if scores[group.kept_metric]:
        return classifier, features, extractor, scores
    return without, features[:, rest], reduced, scores


def check_feature_bearing(cfg: DictConfig, named: str | None = None) -> None:
    """Refuse features read at one bearing's defect orders on data of another (``data=cwru
    features=envelope_orders`` with the twin's default ``bearing=paper``), before any work; ``named``: the bearing the
    records named themselves (:attr:`WindowedDataset.bearing`), checked once they are read."""
    features = cfg.features.get("bearing")
    data = cfg.data.get("bearing") or named
    if features is None or data is None or features.get("name") == data:
        return
    bearing_config(data, "data.bearing")  # a name no bearing config has is named as such, not as a mismatch
    source = "data.bearing" if cfg.data.get("bearing") else "the one the files name"
    raise BearingTwinError(f"features.bearing is {features.get('name')}, the data's bearing ({source}) is {data}: "
                           f"the features must read the defect orders of the bearing recorded: add bearing={data} if "
                           f"the records are of {data}, data.bearing={features.get('name')} if they are of "
                           f"{features.get('name')}")


def data_bearing(cfg: DictConfig, named: str | None = None) -> dict:
    """The bearing the data describe: real-data configs name theirs (``data.bearing``), records may name theirs
    (``named``, :attr:`WindowedDataset.bearing`), the twin's is ``bearing``."""
    name = cfg.data.get("bearing") or named
    if name is None or name == cfg.bearing.get("name"):
        return plain_config(cfg.bearing, "bearing")
    return bearing_config(name)

