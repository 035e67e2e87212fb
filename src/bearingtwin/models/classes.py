"""What every classifier checks of its training data and of what it is asked to predict, and how a label is named
in a message."""

from __future__ import annotations

import numbers

import numpy as np
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

from bearingtwin.errors import BearingTwinError
from bearingtwin.physics.geometry import FAULTS


def state_name(label) -> str:
    """The bearing state a label stands for (every data set labels by FAULTS index); another label as given."""
    return FAULTS[label] if isinstance(label, numbers.Integral) and 0 <= label < len(FAULTS) else str(label)


def training_classes(y) -> tuple[np.ndarray, np.ndarray]:
    """The classes of the training labels ``y`` and the number of windows of each.

    Labels of a single state are refused: there is nothing to tell apart (scikit-learn's SVC raises,
    a network would learn to answer that state whatever it is shown).
    """
    classes, counts = np.unique(np.asarray(y), return_counts=True)
    if classes.size < 2:
        named = state_name(classes[0]) if classes.size else "none"
        raise BearingTwinError(f"the training windows are all of one bearing state ({named}); a classifier needs "
                               "at least 2: add recordings of another state")
    return classes, counts


def training_data(classifier, X, y) -> tuple[np.ndarray, np.ndarray]:
    """``X`` and ``y`` as scikit-learn's own classifiers take them, ``classifier.n_features_in_`` recorded for
    :func:`prediction_data`: labels required and of classes (continuous values are refused), a column of them
    (n, 1) raveled with scikit-learn's DataConversionWarning. Values are left to each model: a scikit-learn
    estimator may take NaN, the network refuses it in its own words."""
    X, y = validate_data(classifier, X, y, ensure_all_finite=False)
    check_classification_targets(y)
    return X, y


def prediction_data(classifier, X) -> np.ndarray:
    """``X`` checked as scikit-learn checks what its classifiers predict: NotFittedError before ``fit`` (both an
    AttributeError, as the missing fitted attribute had raised, and a ValueError), and refused unless it has the
    columns ``classifier`` was fitted on."""
    check_is_fitted(classifier)
    return validate_data(classifier, X, reset=False, ensure_all_finite=False)
