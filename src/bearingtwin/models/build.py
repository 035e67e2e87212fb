"""Build a classifier from its config group (``classifier=cnn_bilstm`` | ``svm`` | ``sklearn``)."""

from __future__ import annotations

import difflib
import inspect

from omegaconf import DictConfig, OmegaConf

from bearingtwin.checks import show_progress_bar
from bearingtwin.errors import BearingTwinError
from bearingtwin.models.sklearn_classifier import SklearnClassifier, make_estimator
from bearingtwin.models.svm import SvmClassifier

# The network's module (torch, Lightning: seconds to import) is imported only when a network is built.
CLASSIFIERS = ("cnn_bilstm", "svm", "sklearn")

SET_BY_THE_RUN = ("random_state", "root_dir")
"""Constructor arguments the run gives (its seed, its folder), never a config."""

TRAINER_SETTINGS = ("max_epochs", "gradient_clip_val", "accelerator", "progress_bar")
"""The network's constructor arguments the ``trainer`` group gives (conf/trainer), not the ``classifier`` group."""

TRAINED_BY_THE_TRAINER = ("cnn_bilstm",)
"""The classifiers the ``trainer`` group (epochs, clipping) applies to; the others ignore it."""


def build_classifier(classifier_cfg: DictConfig, trainer_cfg: DictConfig, seed: int, root_dir: str | None = None):
    """An unfitted scikit-learn-style classifier; every key but ``name`` is a constructor argument.

    ``trainer_cfg`` (epochs, gradient clipping, accelerator) applies to the network only;
    ``seed`` is the run's seed; ``root_dir`` is where Lightning may write (the Hydra run dir).
    """
    show_progress_bar(trainer_cfg.get("progress_bar", False), in_sweep=True)  # a bad value fails here, in a sweep's job
    cls, params, trainer = classifier_settings(classifier_cfg, trainer_cfg)
    if trainer:
        classifier = cls(**params, **trainer, random_state=seed, root_dir=root_dir)
    else:
        classifier = cls(**params, random_state=seed)
    classifier.check_params()  # bad settings fail before any data is built
    return classifier


def classifier_settings(classifier_cfg: DictConfig, trainer_cfg: DictConfig) -> tuple[type, dict, dict]:
    """The classifier's class, its settings and the trainer's (the network's only, else empty), their names
    checked (:func:`check_settings`) but not their values. A sweep checks every job's so before its first starts:
    a misspelt key in a config file fails every job of it, a bad value only its own."""
    params = OmegaConf.to_container(classifier_cfg, resolve=True)
    name = params.pop("name", None)
    if name not in CLASSIFIERS:
        hint = (" (a scikit-learn class named by _target_ is classifier=sklearn's classifier.estimator)"
                if "_target_" in params else "")
        raise BearingTwinError(f"classifier.name={name!r} is not a classifier; choose one of {', '.join(CLASSIFIERS)}"
                               + hint)
    if name in TRAINED_BY_THE_TRAINER:
        from bearingtwin.models.cnn_bilstm import CnnBiLstmClassifier

        cls, trainer = CnnBiLstmClassifier, OmegaConf.to_container(trainer_cfg, resolve=True)
    else:
        cls, trainer = (SvmClassifier if name == "svm" else SklearnClassifier), {}
    check_settings(cls, name, params, trainer)
    if cls is SklearnClassifier:  # its estimator's arguments are its class's settings: checked as the names above
        make_estimator(params.get("estimator"), random_state=0)
    return cls, params, trainer


def check_settings(cls: type, name: str, classifier_params: dict, trainer_params: dict) -> None:
    """Refuse a classifier (or trainer) setting the classifier's class does not take, naming the closest it does.

    A config file's key reaches the constructor unchecked by Hydra (an override's is checked against the
    composed config, a file's is the config), so a misspelt one would fail there as a TypeError."""
    taken = [argument for argument in inspect.signature(cls).parameters if argument not in SET_BY_THE_RUN]
    misplaced = sorted(set(classifier_params) & set(TRAINER_SETTINGS) & set(taken))  # in the classifier's file
    if misplaced:
        raise BearingTwinError(f"classifier.{misplaced[0]}: a trainer setting; give it as trainer.{misplaced[0]}")
    if cls is SklearnClassifier and "_target_" in classifier_params:
        raise BearingTwinError("classifier._target_: the class of classifier=sklearn goes under classifier.estimator "
                               "(estimator: {_target_: <module>.<class>, <argument>: <value>})")
    for group, params in (("classifier", classifier_params), ("trainer", trainer_params)):
        for key in params:
            if key not in taken:
                # A key is matched against its own group's settings.
                mine = [argument for argument in taken if (argument in TRAINER_SETTINGS) == (group == "trainer")]
                match = difflib.get_close_matches(key, mine, n=1, cutoff=0.75)
                hint = f"did you mean {group}.{match[0]}?" if match else f"it takes {', '.join(mine)}"
                raise BearingTwinError(f"{group}.{key}: not a setting of the {name} classifier; {hint}")
