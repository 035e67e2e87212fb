"""The paper's SVM baseline (Table 4, SABO-VMD-SVM): standardize, then an RBF support vector machine.

The scaler sits inside the pipeline so its statistics come from the training set only,
as for the CNN-BiLSTM. The paper gives no SVM hyperparameters; ``conf/classifier/svm.yaml``
holds scikit-learn's defaults (C = 1, RBF kernel, gamma = 1 / (n_features * var)).

A diagnosis also wants class probabilities, which an SVM does not give. :class:`SvmClassifier`
predicts with the SVM exactly as trained (so every accuracy in the results is the plain SVM's)
and estimates probabilities with scikit-learn's ``CalibratedClassifierCV`` (Platt's sigmoid on
cross-validated decision values; ``SVC(probability=True)`` is deprecated for it). At the margin
of two classes the most probable class can then differ from the predicted one.
"""

from __future__ import annotations

import logging
import warnings
from typing import Callable, TypeVar

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.calibration import CalibratedClassifierCV
from sklearn.exceptions import ConvergenceWarning
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC

from bearingtwin.checks import is_finite_number
from bearingtwin.errors import BearingTwinError
from bearingtwin.models.classes import prediction_data, state_name, training_classes, training_data

log = logging.getLogger(__name__)

KERNELS = ("linear", "poly", "rbf", "sigmoid")
CALIBRATION_FOLDS = 5
MAX_ITER = 1_000_000
"""libsvm's iterations before it gives up (its own default never does): ten times what the project's largest fits
need; one that gets there has stalled (:func:`converged`)."""

Fitted = TypeVar("Fitted")


def make_svm(C: float = 1.0, kernel: str = "rbf", gamma: str | float = "scale", random_state: int = 0,
             shrinking: bool = True) -> Pipeline:
    """A StandardScaler + SVC pipeline. ``random_state`` is handed to SVC, which draws from it only for
    ``probability=True`` (never set here: probabilities come from a calibration of its own), so the fit is
    deterministic whatever the seed. ``shrinking``: libsvm's shrinking heuristic, stopped at :data:`MAX_ITER`
    (:func:`converged`); without it libsvm runs to convergence."""
    if not (is_finite_number(C) and C > 0):
        raise BearingTwinError(f"classifier.C must be a positive number, got {C!r}")
    if kernel not in KERNELS:
        raise BearingTwinError(f"classifier.kernel={kernel!r}; choose one of {', '.join(KERNELS)}")
    if not (gamma in ("scale", "auto") or (is_finite_number(gamma) and gamma > 0)):
        raise BearingTwinError(f"classifier.gamma must be 'scale', 'auto' or a positive number, got {gamma!r}")
    return Pipeline([("scale", StandardScaler()), ("svc", SVC(C=C, kernel=kernel, gamma=gamma, random_state=random_state,
                                                             shrinking=shrinking,
                                                             max_iter=MAX_ITER if shrinking else -1))])


def converged(fit: Callable[[bool], Fitted]) -> Fitted:
    """``fit(True)`` (libsvm with its shrinking heuristic), or ``fit(False)`` where that stopped at :data:`MAX_ITER`.

    Shrinking can cycle without end on some problems and row orders (scikit-learn issue #30353): one fold of a
    calibration's cross-validation, a linear SVM of 11520 twin windows, ran for over 24 minutes with its objective
    frozen, where the same problem converges in a second without shrinking. A fit that converges is the same as
    before; one that stalled is fitted again without the heuristic, which solves the same problem. (The warning
    filter is process-wide: no SVM is fitted in a thread of this process.)"""
    with warnings.catch_warnings():
        warnings.filterwarnings("error", message="Solver terminated early", category=ConvergenceWarning)
        try:
            return fit(True)
        except ConvergenceWarning:
            log.info("the SVM's solver stalled with shrinking after %d iterations; fitted again without it", MAX_ITER)
    return fit(False)


class SvmClassifier(ClassifierMixin, BaseEstimator):
    """The scaled SVM of :func:`make_svm`, with calibrated class probabilities.

    Fitted attributes: ``classes_``, ``n_features_in_``, ``svm_`` (the pipeline that predicts), ``calibration_``
    (a ``CalibratedClassifierCV`` around a clone of it, ``ensemble=False``: one SVM fitted on all
    training data, its sigmoid fitted on ``CALIBRATION_FOLDS``-fold cross-validated decisions).
    """

    def __init__(self, C: float = 1.0, kernel: str = "rbf", gamma: str | float = "scale", random_state: int = 0) -> None:
        self.C = C
        self.kernel = kernel
        self.gamma = gamma
        self.random_state = random_state

    def check_params(self) -> None:
        """Raise :class:`BearingTwinError` naming the first impossible parameter."""
        make_svm(self.C, self.kernel, self.gamma, self.random_state)

    def __sklearn_is_fitted__(self) -> bool:
        # fitted once the model is: a fit refused after its data were checked leaves n_features_in_ set
        return hasattr(self, "svm_")

    def fit(self, X, y) -> "SvmClassifier":
        self.check_params()  # a bad parameter named before anything is fitted
        X, y = training_data(self, X, y)
        self.classes_, counts = training_classes(y)
        if counts.min() < 2:
            raise BearingTwinError(f"the SVM's probabilities are calibrated by cross-validation, which needs at least 2 "
                                   f"training windows per class; class {state_name(self.classes_[counts.argmin()])} "
                                   f"has {counts.min()}")
        folds = int(min(CALIBRATION_FOLDS, counts.min()))
        self.svm_ = converged(lambda shrinking: make_svm(self.C, self.kernel, self.gamma, self.random_state,
                                                         shrinking).fit(X, y))
        self.calibration_ = converged(lambda shrinking: CalibratedClassifierCV(
            make_svm(self.C, self.kernel, self.gamma, self.random_state, shrinking), method="sigmoid", cv=folds,
            ensemble=False).fit(X, y))
        return self

    def predict(self, X) -> np.ndarray:
        X = prediction_data(self, X)  # before svm_ is looked up: an unfitted classifier raises NotFittedError
        return self.svm_.predict(X)

    def predict_proba(self, X) -> np.ndarray:
        """(n_samples, n_classes) calibrated probabilities, columns in ``classes_`` order."""
        X = prediction_data(self, X)
        return self.calibration_.predict_proba(X)

    def predict_with_proba(self, X) -> tuple[np.ndarray, np.ndarray]:
        """The SVM's predictions and the calibrated probabilities beside them."""
        return self.predict(X), self.predict_proba(X)

    def pairwise_weights(self) -> dict[tuple[int, int], np.ndarray]:
        """A linear SVM's weights on the standardized features, per pair of classes (one-vs-one, as it decides).

        ``{(a, b): w}`` for every pair of ``classes_`` in scikit-learn's order: a window's decision for the pair
        is ``w . z`` plus an intercept on its standardized features ``z``, positive for ``a``, so a positive weight
        pulls towards ``a`` and the largest magnitudes are what the pair turns on. Only a linear kernel has them.
        """
        if not hasattr(self, "svm_"):
            raise BearingTwinError("SvmClassifier: fit before asking for its weights")
        if self.kernel != "linear":
            raise BearingTwinError(f"classifier.kernel={self.kernel!r}: only a linear SVM has weights per feature")
        pairs = [(a, b) for i, a in enumerate(self.classes_) for b in self.classes_[i + 1:]]
        coef = self.svm_.named_steps["svc"].coef_
        # With two classes scikit-learn's one decision is positive for the second class; with more, each
        # pair's is positive for its first (sklearn.svm.SVC.decision_function).
        coef = -coef if len(self.classes_) == 2 else coef
        return {(int(a), int(b)): weights for (a, b), weights in zip(pairs, coef)}
