"""A fitted SVM as plain files, read back without unpickling anything.

skops.io does this for any scikit-learn object, but importing it walks the whole of scikit-learn
to list the types it trusts (``sklearn.utils.all_estimators`` imports every module, and torch
through scikit-learn's array-API shims): 4-7 s in every process that saves or loads an SVM, a
third of a one-record diagnosis (benchmarks/model_files.py). The SVM of
:mod:`bearingtwin.models.svm` is built from the seven types in :data:`TRUSTED`, whose state
(``__getstate__``) holds only numbers, strings, arrays, lists, tuples and dicts; that is all this
module writes and reads, so it is written here rather than taken from a library. Arrays go to an
``.npz`` file (read with ``allow_pickle=False``), everything else to JSON, and nothing but the
:data:`TRUSTED` types is ever constructed.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from sklearn.calibration import CalibratedClassifierCV, _CalibratedClassifier, _SigmoidCalibration
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC

from bearingtwin.errors import BearingTwinError
from bearingtwin.models.svm import SvmClassifier


def _type_name(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


TRUSTED = {_type_name(cls): cls for cls in (SvmClassifier, Pipeline, StandardScaler, SVC, CalibratedClassifierCV,
                                            _CalibratedClassifier, _SigmoidCalibration)}
"""The only types a model file may name: the SVM classifier and the scikit-learn objects inside it."""


def save_estimator(estimator, path_stem: str | Path) -> list[str]:
    """Write ``estimator`` as ``<stem>.json`` (structure) and ``<stem>.npz`` (arrays); returns the two names."""
    path_stem = Path(path_stem)
    arrays: dict[str, np.ndarray] = {}
    structure = _encode(estimator, arrays)
    path_stem.with_suffix(".json").write_text(json.dumps(structure))
    np.savez(path_stem.with_suffix(".npz"), **arrays)
    return [path_stem.with_suffix(".json").name, path_stem.with_suffix(".npz").name]


def load_estimator(path_stem: str | Path):
    """The estimator :func:`save_estimator` wrote at ``path_stem``."""
    path_stem = Path(path_stem)
    try:
        structure = json.loads(path_stem.with_suffix(".json").read_text())
        with np.load(path_stem.with_suffix(".npz"), allow_pickle=False) as stored:
            arrays = {name: stored[name] for name in stored.files}
        return _decode(structure, arrays, path_stem)
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise BearingTwinError(f"{path_stem}: not a saved model ({type(error).__name__}: {error})") from None


def _encode(value, arrays: dict):
    if isinstance(value, np.generic):  # before float: np.float64 is one, and is read back as itself
        return {"scalar": value.dtype.str, "value": value.item()}
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, np.ndarray):
        if value.dtype.hasobject:
            raise BearingTwinError(f"cannot save an array of Python objects (dtype {value.dtype})")
        key = f"a{len(arrays)}"
        arrays[key] = value
        return {"array": key}
    if isinstance(value, (list, tuple)):
        return {"tuple" if isinstance(value, tuple) else "list": [_encode(item, arrays) for item in value]}
    if isinstance(value, dict):
        if not all(isinstance(key, str) for key in value):
            raise BearingTwinError("cannot save a dict with keys that are not strings")
        return {"dict": {key: _encode(item, arrays) for key, item in value.items()}}
    name = _type_name(type(value))
    if name not in TRUSTED:
        raise BearingTwinError(f"cannot save a {name}: a model file holds only {', '.join(TRUSTED)}")
    return {"object": name, "state": _encode(value.__getstate__(), arrays)}


def _decode(node, arrays: dict, source: Path):
    if node is None or isinstance(node, (bool, int, float, str)):
        return node
    (kind,) = set(node) - {"value", "state"}
    if kind == "array":
        return arrays[node["array"]]
    if kind == "scalar":
        return np.dtype(node["scalar"]).type(node["value"])
    if kind in ("list", "tuple"):
        items = [_decode(item, arrays, source) for item in node[kind]]
        return tuple(items) if kind == "tuple" else items
    if kind == "dict":
        return {key: _decode(item, arrays, source) for key, item in node["dict"].items()}
    if kind == "object":
        if node["object"] not in TRUSTED:
            raise BearingTwinError(f"{source}: names the type {node['object']}, which a model file may not hold")
        cls = TRUSTED[node["object"]]
        estimator, state = cls.__new__(cls), _decode(node["state"], arrays, source)
        if hasattr(estimator, "__setstate__"):  # scikit-learn's estimators (it checks the version that saved them)
            estimator.__setstate__(state)
        else:  # a plain object (_CalibratedClassifier): its state is its __dict__
            estimator.__dict__.update(state)
        return estimator
    raise BearingTwinError(f"{source}: unknown entry {kind!r}")
