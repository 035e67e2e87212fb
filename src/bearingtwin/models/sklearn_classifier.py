"""Any scikit-learn classifier, named in its config by Hydra's ``_target_`` (``classifier=sklearn``).

``conf/classifier/sklearn.yaml`` holds an ``estimator`` node that Hydra instantiates: its ``_target_`` names the
class, every other key is a constructor argument (nested ``_target_`` nodes, e.g. a ``CalibratedClassifierCV``
around a ``LinearSVC``, are built too). The features are standardized first, on the training set only, as for the
SVM and the network. A diagnosis reports class probabilities, so the estimator must give them (``predict_proba``);
one that does not (``RidgeClassifier``, ``LinearSVC``) is refused before any data is built, with the wrapper that
adds them. Where the class takes a ``random_state`` left at None, the run's seed is given to it. In Python the
estimator may also be given built (``SklearnClassifier(RandomForestClassifier(n_estimators=300))``), checked alike;
its parameters are then nested ones (``set_params(estimator__n_estimators=10)``, a grid search over them).

A fitted model is saved with skops.io (scikit-learn's maintained safe format) and read back trusting only types of
scikit-learn, numpy and scipy: a model file naming any other type is refused, as no file is ever unpickled.
"""

from __future__ import annotations

import difflib
import importlib
import inspect
import re
from pathlib import Path

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin, clone, is_classifier
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils import get_tags

from bearingtwin.errors import BearingTwinError
from bearingtwin.models.classes import prediction_data, training_classes, training_data

TRUSTED_PACKAGES = ("sklearn", "numpy", "scipy")
"""The packages whose types a saved model may hold (skops.io lists every other as untrusted)."""


DEFAULT_ESTIMATOR = {"_target_": "sklearn.ensemble.RandomForestClassifier"}
"""The classifier of ``SklearnClassifier()`` given none: conf/classifier/sklearn.yaml's."""


def make_estimator(spec: dict | BaseEstimator | None, random_state: int):
    """The unfitted estimator ``spec`` describes (a ``_target_`` and its arguments; or a clone of ``spec``, a built
    scikit-learn estimator, which is left as it is; None: :data:`DEFAULT_ESTIMATOR`), with ``random_state`` given
    where the class takes one left at None; refused in one line when it is no classifier giving probabilities."""
    spec = DEFAULT_ESTIMATOR if spec is None else spec
    if isinstance(spec, BaseEstimator):
        estimator, named = clone(spec), f"classifier.estimator ({_described(spec)})"
    else:
        estimator, named = _instantiate(spec), f"classifier.estimator._target_={spec['_target_']}"
    if not (isinstance(estimator, BaseEstimator) and is_classifier(estimator)):
        raise BearingTwinError(f"{named} is not a scikit-learn classifier")
    inner = [estimator, *(value for value in estimator.get_params(deep=True).values() if isinstance(value, BaseEstimator))]
    foreign = [type(part) for part in inner if type(part).__module__.split(".")[0] not in TRUSTED_PACKAGES]
    if foreign:  # its model file could never be read back (load trusts no other package's types): refused now
        raise BearingTwinError(f"classifier.estimator: {foreign[0].__module__}.{foreign[0].__qualname__} is no "
                               f"{', '.join(TRUSTED_PACKAGES)} class; a model file holds only theirs")
    # scikit-learn checks its arguments' values only when fitting: checked here, nested estimators' too, before the
    # features' minutes
    for part in inner:
        try:
            part._validate_params()
        except (TypeError, ValueError) as error:  # scikit-learn's InvalidParameterError is both
            raise BearingTwinError(f"classifier.estimator: {_first_line(error)}") from None
    if not hasattr(estimator, "predict_proba"):
        wrapped = (f"CalibratedClassifierCV({_described(spec)})" if isinstance(spec, BaseEstimator) else
                   f"classifier.estimator._target_=sklearn.calibration.CalibratedClassifierCV "
                   f"+classifier.estimator.estimator._target_={spec['_target_']}")
        raise BearingTwinError(f"{named} gives no class probabilities (predict_proba), which a diagnosis reports; "
                               f"wrap it: {wrapped}")
    unseeded = {key: random_state for key, value in estimator.get_params(deep=True).items()
                if key.split("__")[-1] == "random_state" and value is None}
    estimator.set_params(**unseeded)  # one seed fixes the run, a wrapped estimator's draws too
    return estimator


def _instantiate(spec: dict):
    """What Hydra builds of the config ``spec``, refused in one line where it cannot."""
    from hydra.errors import InstantiationException
    from hydra.utils import instantiate

    if not isinstance(spec, dict) or "_target_" not in spec:
        raise BearingTwinError("classifier.estimator needs _target_: the scikit-learn class to use (e.g. "
                               "classifier.estimator._target_=sklearn.ensemble.RandomForestClassifier)")
    target = spec["_target_"]
    try:
        return instantiate(spec, _convert_="all")
    except InstantiationException as error:  # Hydra's message runs over lines; its cause says what went wrong
        cause = error.__cause__
        if isinstance(cause, ImportError):  # no such class: Hydra's last line asks the question that helps
            raise BearingTwinError(f"classifier.estimator._target_={target}: {str(cause).splitlines()[-1]}"
                                   + _closest_class(target)) from None
        raise BearingTwinError(f"classifier.estimator ({target}): {_first_line(cause or error)}"
                               + _closest_argument(target, cause)) from None


def _described(spec: dict | BaseEstimator) -> str:
    """The estimator as a message names it: its config's ``_target_``, or a built one's repr on one line."""
    spec = DEFAULT_ESTIMATOR if spec is None else spec
    return " ".join(repr(spec).split()) if isinstance(spec, BaseEstimator) else spec["_target_"]


def _first_line(error: Exception) -> str:
    """The error's first sentence on one line: its first line, and those after it while a sentence runs on (Hydra
    wraps a refusal over several lines mid-sentence)."""
    lines = str(error).split("\n")
    first = lines[0]
    for line in lines[1:]:
        if first.rstrip().endswith((".", ":", "!", "?")) or not line.strip():
            break
        first += " " + line
    return " ".join(first.split())


def _closest_class(target: str) -> str:
    """" (did you mean <module>.<class>?)" for a class name close to one its module holds, else ""."""
    module_name, _, name = target.rpartition(".")
    try:
        module = importlib.import_module(module_name)
    except (ImportError, ValueError):
        return ""
    match = difflib.get_close_matches(name, [member for member in dir(module) if not member.startswith("_")], n=1,
                                      cutoff=0.75)
    return f" (did you mean {module_name}.{match[0]}?)" if match else ""


def _closest_argument(target: str, cause: Exception | None) -> str:
    """" (did you mean <argument>?)" for an unexpected keyword argument close to one the class takes, else ""."""
    from hydra.utils import get_class

    named = re.search(r"unexpected keyword argument '(\w+)'", str(cause))
    if named is None:
        return ""
    try:
        arguments = inspect.signature(get_class(target)).parameters
    except (ValueError, TypeError):  # a _target_ that is no class (a function): no arguments to match against
        return ""
    match = difflib.get_close_matches(named.group(1), list(arguments), n=1, cutoff=0.75)
    return f" (did you mean classifier.estimator.{match[0]}?)" if match else ""


class SklearnClassifier(ClassifierMixin, BaseEstimator):
    """Standardized features, then the scikit-learn classifier ``estimator`` describes.

    Parameters:
        estimator: the classifier's config as a dict, ``{"_target_": "<module>.<class>", <argument>: <value>, ...}``,
            or a scikit-learn classifier (unfitted; a clone of it is fitted); None: a random forest, as the config's.
        random_state: the run's seed, given to the class where it takes one left at None.

    Fitted attributes: ``classes_``, ``n_features_in_``, ``model_`` (the fitted scaler + classifier pipeline),
    ``n_windows_`` (the training windows).
    """

    def __init__(self, estimator: dict | BaseEstimator | None = None, random_state: int = 0) -> None:
        self.estimator = estimator
        self.random_state = random_state

    def check_params(self) -> None:
        """Raise :class:`BearingTwinError` naming what is wrong with ``estimator``, before any data is built."""
        make_estimator(self.estimator, self.random_state)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        # NaN is left to the estimator (StandardScaler passes it on, a forest takes it): allowed where a built one
        # allows it (a config's class is known only once built, when fitted)
        if isinstance(self.estimator, BaseEstimator):
            tags.input_tags.allow_nan = get_tags(self.estimator).input_tags.allow_nan
        return tags

    def set_params(self, **params) -> "SklearnClassifier":
        """scikit-learn's, and a nested value of a config dict refused in one line saying how to set it (scikit-learn
        sets nested values only on a built estimator: a dict has no set_params)."""
        nested = next((key for key in params if key.startswith("estimator__")), None)
        if nested and not isinstance(params.get("estimator", self.estimator), BaseEstimator):
            given = "a config dict" if self.estimator is not None else "not given (the config's random forest)"
            raise BearingTwinError(f"SklearnClassifier.set_params({nested}=...): estimator is {given}, whose values "
                                   f"set_params does not reach; give the whole dict (estimator={{...}}) or a built "
                                   f"scikit-learn estimator, whose parameters it does")
        return super().set_params(**params)

    def __sklearn_is_fitted__(self) -> bool:
        # fitted once the model is: a fit refused after its data were checked leaves n_features_in_ set
        return hasattr(self, "model_")

    def fit(self, X, y) -> "SklearnClassifier":
        X, y = training_data(self, X, y)
        self.classes_, _ = training_classes(y)
        model = Pipeline([("scale", StandardScaler()), ("classifier", make_estimator(self.estimator, self.random_state))])
        self.n_windows_ = len(y)
        self.model_ = self._said(lambda: model.fit(X, y))
        return self

    def _said(self, call):
        """``call()``, a setting the training windows cannot meet (more neighbours than windows: scikit-learn finds
        it fitting or predicting) refused in one line naming the estimator."""
        try:
            return call()
        except ValueError as error:
            raise BearingTwinError(f"classifier.estimator ({_described(self.estimator)}), fitted on {self.n_windows_} "
                                   f"training windows: {_first_line(error)}") from None

    def predict(self, X) -> np.ndarray:
        X = prediction_data(self, X)  # what is wrong with X is said in scikit-learn's words, not as a setting's
        return self._said(lambda: self.model_.predict(X))

    def predict_proba(self, X) -> np.ndarray:
        """(n_samples, n_classes) class probabilities, columns in ``classes_`` order."""
        X = prediction_data(self, X)
        return self._said(lambda: self.model_.predict_proba(X))

    def predict_with_proba(self, X) -> tuple[np.ndarray, np.ndarray]:
        return self.predict(X), self.predict_proba(X)

    def save(self, folder: Path) -> dict:
        """Write the fitted pipeline to ``folder`` (skops.io); returns what :meth:`load` needs besides the folder."""
        import skops.io

        skops.io.dump(self.model_, Path(folder) / "sklearn.skops")
        # A built estimator is no JSON: the file holds it (fitted), and load takes it back from there
        return {"estimator": self.estimator if isinstance(self.estimator, dict) else None,
                "random_state": self.random_state,
                "classes": self.classes_.tolist(), "n_windows": int(self.n_windows_),
                "files": ["sklearn.skops"]}

    @classmethod
    def load(cls, folder: Path, state: dict) -> "SklearnClassifier":
        """The classifier :meth:`save` wrote, its file read trusting only :data:`TRUSTED_PACKAGES`' types."""
        import skops.io

        path = Path(folder) / "sklearn.skops"
        try:
            types = skops.io.get_untrusted_types(file=path)
        except (OSError, ValueError) as error:
            raise BearingTwinError(f"{path}: not a saved model ({error})") from None
        foreign = [name for name in types if name.split(".")[0] not in TRUSTED_PACKAGES]
        if foreign:
            raise BearingTwinError(f"{path}: names the type {foreign[0]}, which a model file may not hold (only "
                                   f"{', '.join(TRUSTED_PACKAGES)} types are read)")
        model = skops.io.load(path, trusted=types)
        classifier = cls(clone(model[-1]) if state["estimator"] is None else state["estimator"], state["random_state"])
        classifier.model_, classifier.n_features_in_ = model, model.n_features_in_
        classifier.classes_ = np.asarray(state["classes"])
        classifier.n_windows_ = state.get("n_windows")
        return classifier
