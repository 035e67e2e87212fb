"""What every classifier checks of its training labels, and how a label is named in a message."""

from __future__ import annotations

import numbers

import numpy as np

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
