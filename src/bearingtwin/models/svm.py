"""The paper's SVM baseline (Table 4, SABO-VMD-SVM): standardize, then an RBF support vector machine.

The scaler sits inside the pipeline so its statistics come from the training set only,
as for the CNN-BiLSTM. The paper gives no SVM hyperparameters; ``conf/classifier/svm.yaml``
holds scikit-learn's defaults (C = 1, RBF kernel, gamma = 1 / (n_features * var)).
"""

from __future__ import annotations

from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC

from bearingtwin.errors import BearingTwinError

KERNELS = ("linear", "poly", "rbf", "sigmoid")


def make_svm(C: float = 1.0, kernel: str = "rbf", gamma: str | float = "scale", random_state: int = 0) -> Pipeline:
    """A StandardScaler + SVC pipeline; ``random_state`` only matters for SVC's tie breaking."""
    if not C > 0:
        raise BearingTwinError(f"classifier.C must be positive, got {C}")
    if kernel not in KERNELS:
        raise BearingTwinError(f"classifier.kernel={kernel!r}; choose one of {', '.join(KERNELS)}")
    if not (gamma in ("scale", "auto") or (isinstance(gamma, (int, float)) and gamma > 0)):
        raise BearingTwinError(f"classifier.gamma must be 'scale', 'auto' or a positive number, got {gamma!r}")
    return Pipeline([("scale", StandardScaler()), ("svc", SVC(C=C, kernel=kernel, gamma=gamma, random_state=random_state))])
