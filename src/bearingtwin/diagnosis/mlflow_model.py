"""A trained pipeline as an MLflow model: pyfunc flavor, signature, input example, registry.

``mlflow.pyfunc.load_model("runs:/<run_id>/model").predict(windows, params={"rpm": 1797})``
takes raw windows (n, window_length) at the model's sampling rate and returns one row per
window: ``state`` and one probability column per class (the classifier's), ``decided_by``
(``physics`` or ``classifier``) for a model whose physics may decide a window (``physics_first``), and
``level_unseen`` for a model that reads the windows' level (a window a decade or more outside the training windows'
levels: an undeclared unit or gain, the answer not to be trusted), and ``feature_unseen`` for a model that kept its
training features' range (the feature lying farthest beyond it, "" where none does: the classifier extrapolates).
``rpm`` (rev/min; 0 = not given) is needed by models whose features are read on the shaft-order
axis and by ``physics_first`` models; ``bearing`` (a ``conf/bearing/<name>.yaml``; default the
model's own) is the recorded bearing, whose defect orders those features and that physics read. ``fs`` (Hz) and
``unit`` (``g``, ``m/s^2``, ...), where given, are the windows' own: a rate other than the model's is refused (the
windows' lines would stand at other frequencies, and the model reads them without a word), windows in another
acceleration unit are converted to the model's, and a unit is refused where :func:`unit_for_model` refuses a record's
or is no unit known here; ``scale`` (0 = not given) multiplies the windows first, ``unit`` then naming the
product's (a 100 mV/g sensor's volts: ``"scale": 10, "unit": "g"``), as ``bearingtwin-diagnose``'s ``scale=`` does.
The same model is served by
``mlflow models serve -m models:/<name>@<alias> --env-manager local`` and queried with
``{"inputs": [[...], ...], "params": {"rpm": 1797, "bearing": "cwru_6203", "fs": 12000, "unit": "g"}}``.
"""

from __future__ import annotations

import atexit
import functools
import math
import re
import shutil
import sys
import tempfile
import threading
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from mlflow.exceptions import MlflowException
from mlflow.protos.databricks_pb2 import INVALID_PARAMETER_VALUE
from mlflow.pyfunc import PythonModel

from bearingtwin.checks import positive_number
from bearingtwin.data.units import METRES_PER_S2, quantity_of, unit_key
from bearingtwin.diagnosis.pipeline import DiagnosisPipeline, unit_for_model
from bearingtwin.errors import BearingTwinError
from bearingtwin.tracking.mlflow_logging import registry_uri, use_registry
from bearingtwin.tracking.provenance import installed_versions

ARTIFACT_PATH = "model"
STATE_COLUMN = "state"
DECIDED_BY_COLUMN = "decided_by"
"""``physics`` or ``classifier`` per window, in the frame of a model whose physics may decide a window."""
LEVEL_UNSEEN_COLUMN = "level_unseen"
"""Per window, in the frame of a model that reads the windows' level: a level a decade or more outside the training
windows' (an undeclared unit or gain), where the classifier's answer is not to be trusted."""
FEATURE_UNSEEN_COLUMN = "feature_unseen"
"""Per window, in the frame of a model that kept its training features' range: the feature lying farthest beyond it
(by more than a quarter of its width), "" where none does: where the classifier extrapolates, unawares."""
RUNTIME_PACKAGES = ("bearingtwin", "numpy", "scipy", "pandas", "scikit-learn", "torch", "lightning", "mlflow")


class ModelInputError(MlflowException, BearingTwinError):
    """Input a model cannot diagnose: a :class:`BearingTwinError` for bearingtwin's own callers, and an
    MLflow error of the request for a model server, which answers any other exception with a generic
    "unexpected error" and leaves the reason in the stack trace."""

    def __init__(self, message: str):
        super().__init__(message, error_code=INVALID_PARAMETER_VALUE)


class DiagnosisModel(PythonModel):
    """pyfunc face of a :class:`DiagnosisPipeline` (loaded from the ``pipeline`` artifact)."""

    def load_context(self, context) -> None:
        self.pipeline = DiagnosisPipeline.load(context.artifacts["pipeline"])
        use_one_thread_per_library()

    def predict(self, context, model_input: np.ndarray, params: dict | None = None) -> pd.DataFrame:
        params = params or {}
        try:
            rpm = params.get("rpm") or None  # 0, the signature's default: not given
            windows = np.asarray(model_input, dtype=np.float64)
            self.pipeline.check_window_shape(windows)
            flat = np.flatnonzero(np.ptp(windows, axis=-1) == 0) if windows.ndim == 2 and windows.size else []
            if len(flat):  # said of the request, where the features would name an array index
                raise BearingTwinError(f"window {flat[0]} of the request is constant (every sample equal): no vibration "
                                       "to diagnose")
            scale = params.get("scale") or None  # 0, the signature's default: not given
            if scale is not None:  # a sensor's volts times 1 / its sensitivity: the unit given is then the product's
                windows = windows * positive_number(scale, "scale", "the unit given per unit of the samples")
            windows = in_model_terms(self.pipeline, windows, params.get("fs") or None, params.get("unit") or "")
            return predictions_frame(self.pipeline, windows,
                                     None if rpm is None else positive_number(rpm, "rpm", "rev/min"),
                                     recorded_bearing(self.pipeline, params.get("bearing")))
        except BearingTwinError as error:
            message = str(error)
            if message.startswith("rpm: ") and not params.get("rpm"):  # a speed beside "inputs" is read nowhere
                message += ' (a request gives it under "params", beside "inputs": {"params": {"rpm": 1797}})'
            raise ModelInputError(message) from error


def in_model_terms(pipeline: DiagnosisPipeline, windows: np.ndarray, fs: float | None, unit: str) -> np.ndarray:
    """A request's ``windows`` as the model reads them: sampled at ``fs`` Hz (None: not given), refused unless it is the
    model's rate (a window of its length at another rate is another stretch of time, which no conversion of the
    request restores; bearingtwin-diagnose resamples a record); in ``unit`` (empty: not given), held against the
    model's as a diagnosed record's is (:func:`unit_for_model`: converted between acceleration units, g and m/s^2
    differing by 9.81, which no level check sees; a voltage, a velocity or a displacement refused where the model
    reads what they change), but text no unit known here is refused by every model (a request is answered without
    its notes, where a diagnosis would say it read it as the model's)."""
    if fs is not None and not math.isclose(positive_number(fs, "fs", "Hz"), pipeline.fs_hz, rel_tol=1e-6):
        raise BearingTwinError(f"params fs {fs:g} Hz: the model reads windows sampled at {pipeline.fs_hz:g} Hz; resample "
                               "the record to it before cutting windows (bearingtwin-diagnose reads a record at any rate)")
    if not unit:
        return windows
    source = f"params unit {unit!r}"
    factor, _, check = unit_for_model(unit, pipeline, source)
    own_unit = pipeline.unit and unit_key(unit) == unit_key(pipeline.unit)  # the model's own, whatever it is
    if not own_unit and (check == "assumed" or quantity_of(unit) is None):  # a diagnosis reads it as none stated
        own = f" (the model's is {pipeline.unit})" if pipeline.unit else ""
        raise BearingTwinError(f"{source}: no unit known here; give one of {', '.join(METRES_PER_S2)}{own}")
    return windows if factor is None else windows * factor


def recorded_bearing(pipeline: DiagnosisPipeline, name: str | None) -> dict | None:
    """The config of the bearing named ``name`` (None: the model's own, for an empty or absent name)."""
    if not name or name == (pipeline.bearing or {}).get("name"):
        return None
    with _BEARINGS_LOCK:  # a model server answers requests in threads; Hydra's composition is process-wide
        return _bearing_config(str(name))


_BEARINGS_LOCK = threading.Lock()


@functools.lru_cache(maxsize=None)
def _bearing_config(name: str) -> dict:
    from bearingtwin.config import bearing_config

    return bearing_config(name, "params bearing", own_hint=False)


def use_one_thread_per_library() -> None:
    """One thread each for numba (VMD) and torch (the network) in a diagnosing process.

    Their two OpenMP pools spin against each other on a small machine: measured on 2 cores
    (benchmarks/RESULTS.md), one LSTM forward pass took ~140 ms with two threads each and
    ~1 ms with one; a diagnosis batch of windows is too small to gain from more threads.
    """
    import numba

    numba.set_num_threads(1)
    if "torch" in sys.modules:  # loaded by a network's pipeline; an SVM model's process need not import it
        sys.modules["torch"].set_num_threads(1)


def predictions_frame(pipeline: DiagnosisPipeline, windows: np.ndarray, rpm: float | None,
                      bearing: dict | None = None) -> pd.DataFrame:
    """``state`` and one probability column per class (the classifier's), one row per window; who decided each window
    (``decided_by``) when the model lets the physics decide some (``physics_first``); and whether its level lies a
    decade or more outside the training windows' (``level_unseen``) when the model reads the level
    (:meth:`DiagnosisPipeline.levels_unseen`); and the feature lying farthest beyond the training windows' range
    (``feature_unseen``, "" where none does) when the model kept that range (:meth:`DiagnosisPipeline.features_unseen`)."""
    decision = pipeline.decide(windows, rpm, bearing)
    frame = pd.DataFrame(decision.probabilities, columns=pipeline.class_names)
    frame.insert(0, STATE_COLUMN, decision.states)
    if pipeline.physics_first is not None:
        frame[DECIDED_BY_COLUMN] = np.where(decision.by_physics, "physics", "classifier")
    if pipeline.levels_seen is not None:  # flagged, not refused: a louder machine is a level unseen too
        frame[LEVEL_UNSEEN_COLUMN] = pipeline.levels_unseen(np.std(windows, axis=1))
    if pipeline.feature_range is not None:  # flagged, not refused: the physics may still decide such a window
        frame[FEATURE_UNSEEN_COLUMN] = decision.unseen.astype(str)
    return frame


def _requirements() -> list[str]:
    return [package if version is None else f"{package}=={version}"
            for package, version in installed_versions(RUNTIME_PACKAGES).items()]


def log_diagnosis_model(tracking_uri: str, experiment_id: str, run_id: str, pipeline: DiagnosisPipeline,
                        example_windows: np.ndarray, example_rpm: float | None):
    """Log ``pipeline`` as the run's MLflow model ``model``; returns MLflow's ``ModelInfo``.

    The signature is a float64 tensor (n, window_length) in, the prediction frame out, and
    ``rpm``, ``bearing`` (the model's own by default), ``fs`` and ``unit`` (the windows', not checked by default) as
    parameters. A model that cannot diagnose (``vmd_params=per_class``) is logged
    all the same, with a signature built without predicting, and refuses at prediction time.
    """
    import mlflow
    from mlflow.models import Model, infer_signature
    from mlflow.types import Schema, TensorSpec

    mlflow.set_tracking_uri(tracking_uri)  # Model.log resolves the store globally; jobs in one process run one at a time
    mlflow.set_experiment(experiment_id=experiment_id)
    windows = np.asarray(example_windows, dtype=np.float64)[:2]
    try:
        output = predictions_frame(pipeline, windows, example_rpm)
        can_diagnose = True
    except BearingTwinError:
        output = pd.DataFrame({STATE_COLUMN: ["normal"] * len(windows), **{n: np.zeros(len(windows)) for n in pipeline.class_names}})
        can_diagnose = False
    params = {"rpm": float(example_rpm or 0.0), "bearing": str((pipeline.bearing or {}).get("name", "")),
              "fs": float(pipeline.fs_hz), "unit": pipeline.unit}
    # The signature's defaults are what a request without them gets: no speed (0), the model's own bearing, a rate
    # and unit not stated. The example's speed as the default would read any window at that speed, unasked.
    signature = infer_signature(windows, output, params={**params, "rpm": 0.0, "fs": 0.0, "unit": "", "scale": 0.0})
    # Windows of any length pass MLflow's check to meet the pipeline's (check_window_shape), which names the length
    # the model reads in a line: MLflow's refusal of a shape prints the whole request back (tens of kB).
    signature.inputs = Schema([TensorSpec(np.dtype(np.float64), (-1, -1))])
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        # A model that cannot diagnose has no example to give, by design: MLflow's warning would say it was forgotten.
        warnings.filterwarnings("ignore", message=".*An input example was not provided")
        pipeline.save(Path(folder) / "pipeline")
        return Model.log(
            artifact_path=None,
            name=ARTIFACT_PATH,
            flavor=mlflow.pyfunc,
            run_id=run_id,
            python_model=str(Path(__file__).with_name("pyfunc_model.py")),
            artifacts={"pipeline": str(Path(folder) / "pipeline")},
            signature=signature,
            input_example=(windows, params) if can_diagnose else None,
            pip_requirements=_requirements(),
            metadata={"window_length": pipeline.window_length, "fs_hz": pipeline.fs_hz,
                      "class_names": pipeline.class_names, "config_hash": pipeline.config_hash,
                      "can_diagnose": can_diagnose, "unit": pipeline.unit},
        )


def register_model(tracking_uri: str, model_uri: str, name: str, alias: str | None = None, description: str = "",
                   tags: dict[str, str] | None = None) -> tuple[str, str | None]:
    """Register a logged model under ``name`` in MLflow's Model Registry (same store), with the ``description`` and
    ``tags`` the registry shows beside the version; returns the version, and the version ``alias`` named before it
    was moved to this one (None where it named none)."""
    import mlflow
    from mlflow import MlflowClient
    from mlflow.exceptions import MlflowException

    mlflow.set_tracking_uri(tracking_uri)
    registry = use_registry(tracking_uri)
    version = str(mlflow.register_model(model_uri, name, tags=tags).version)
    client = MlflowClient(tracking_uri=tracking_uri, registry_uri=registry)
    if description:
        client.update_model_version(name, version, description=description)
    before = None
    if alias:
        try:
            before = str(client.get_model_version_by_alias(name, alias).version)
        except MlflowException:  # the alias is new
            pass
        client.set_registered_model_alias(name, alias, version)
    return version, before


def model_params(model) -> set[str]:
    """The names of the parameters a loaded pyfunc model's signature declares."""
    schema = model.metadata.get_params_schema()
    return set() if schema is None else {spec.name for spec in schema.params}


def model_identity(model_uri: str, tracking_uri: str) -> str:
    """What ``model_uri`` names now, as ``<run id>/<model uuid>``: an alias moves to another model, so work kept for
    an earlier one is told from work for this one by it, not by the URI."""
    import mlflow
    from mlflow.exceptions import MlflowException

    mlflow.set_tracking_uri(tracking_uri)
    use_registry(tracking_uri)
    try:
        info = mlflow.models.get_model_info(model_uri)
    except (MlflowException, OSError) as error:
        raise BearingTwinError(f"model={model_uri}: not found in {_store_of(model_uri, tracking_uri)} "
                               f"({str(error).strip().splitlines()[0]})") from None
    return f"{info.run_id}/{info.model_uuid}"


def _store_of(model_uri: str, tracking_uri: str) -> str:
    """The store a model URI is read from, as a message names it: a ``models:/`` URI's registry (MLFLOW_REGISTRY_URI
    where it is not the tracking store), else the tracking store."""
    registry = registry_uri(tracking_uri)
    return f"the registry {registry}" if model_uri.startswith("models:/") and registry != tracking_uri else tracking_uri


def _version_named(model_uri: str, tracking_uri: str) -> str:
    """``model_uri`` with a registry alias replaced by the version it names now (``models:/sim2real@champion`` ->
    ``models:/sim2real/3``); other URIs as given."""
    if not model_uri.startswith("models:/") or "@" not in model_uri:
        return model_uri
    from mlflow import MlflowClient

    name, alias = model_uri.removeprefix("models:/").rsplit("@", 1)
    version = MlflowClient(tracking_uri=tracking_uri, registry_uri=registry_uri(tracking_uri)).get_model_version_by_alias(name, alias)
    return f"models:/{name}/{version.version}"


MODEL_URI_FORMS = "runs:/<run id>/model, models:/<name>/<version> or models:/<name>@<alias>"
"""What ``model=`` takes from a store, as an error names it (a model's folder on disk too)."""
WHAT_A_RUN_HOLDS = {"sweep": "a sweep's parent run, which holds no model: its jobs' runs do",
                    "diagnose": "a diagnosis run, which holds verdicts, not a model",
                    "twin": "a bearingtwin-twin run, which holds a twin report, not a model",
                    "report": "a bearingtwin-report run, which holds a results table, not a model"}
"""The runs of the project's own that log no model (tag ``bt.kind``), in words."""
MOST_NAMED = 10
"""At most this many registered models or versions are named in an error (the newest first)."""


def _registry_words(model_uri: str, tracking_uri: str) -> str:
    """For a ``models:/`` URI that cannot be loaded, what the registry holds under its name (or at all), so that the
    one meant can be given: its versions and aliases, or the registered models' names; "" for another URI."""
    if not model_uri.startswith("models:/"):
        return ""
    from mlflow import MlflowClient
    from mlflow.exceptions import MlflowException

    client = MlflowClient(tracking_uri=tracking_uri, registry_uri=registry_uri(tracking_uri))
    name = re.split(r"[/@]", model_uri.removeprefix("models:/"), maxsplit=1)[0]
    try:
        model = client.get_registered_model(name)
    except MlflowException:  # no model of that name: the names there are
        try:
            names = [model.name for model in client.search_registered_models(max_results=MOST_NAMED + 1)]
        except MlflowException:
            return ""
        listed = ", ".join(names[:MOST_NAMED]) + (", ..." if len(names) > MOST_NAMED else "")
        return f"; registered there: {listed}" if names else "; no model is registered there"
    try:
        versions = sorted(int(v.version) for v in client.search_model_versions(f"name = '{name}'"))
    except MlflowException:
        versions = []
    aliases = ", ".join(f"@{alias} (version {version})" for alias, version in sorted(model.aliases.items()))
    newest = [str(v) for v in versions[-MOST_NAMED:]]
    words = f"; {name}'s versions: {', '.join(newest)}" if versions else f"; {name} has no version"
    words += f", its aliases: {aliases}" if aliases else ", no alias"
    if model_uri == f"models:/{name}":  # neither a version nor an alias
        words += f" (give one: models:/{name}/<version> or models:/{name}@<alias>)"
    return words


def _unfinished_run_words(model_uri: str, tracking_uri: str) -> str:
    """For a ``runs:/<id>/...`` model that cannot be loaded, the words saying that its run holds no model (a sweep's
    parent, a diagnosis) or did not finish (a run stopped while it logged its model leaves the model part-written),
    else ""."""
    if not model_uri.startswith("runs:/"):
        return ""
    from mlflow import MlflowClient
    from mlflow.exceptions import MlflowException

    run_id = model_uri.removeprefix("runs:/").split("/", 1)[0]
    try:
        run = MlflowClient(tracking_uri=tracking_uri).get_run(run_id)
    except MlflowException:  # no such run: MLflow's own reason says so
        return ""
    status, kind = run.info.status, run.data.tags.get("bt.kind")
    if kind in WHAT_A_RUN_HOLDS:
        return f"; run {run_id} is {WHAT_A_RUN_HOLDS[kind]}"
    if status == "FINISHED":
        return ""
    if status in ("FAILED", "KILLED"):
        return f"; its run {run_id} ended {status}, so its model may not have been logged whole"
    return (f"; its run {run_id} is still marked {status}: its process may have stopped before it logged its model "
            "whole (the next bearingtwin command on that machine marks such a run KILLED)")


def _download_folder() -> str:
    """A new temporary folder, removed when the process ends (the loaded model may read its files until then)."""
    folder = tempfile.mkdtemp(prefix="bearingtwin-model-")
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return folder


def _own_folder(model_uri: str) -> bool:
    """Whether ``model_uri`` is a model's own folder on disk (one holding MLmodel), read without any store."""
    return (Path(model_uri).expanduser() / "MLmodel").is_file()


def deleted_run_words(model, model_uri: str, tracking_uri: str) -> str:
    """Where the run that logged a model loaded from a store is deleted there (its owner removed it; ``mlflow gc``
    removes its files for good), that, in words; "" otherwise, and for a model read from its own folder."""
    from mlflow import MlflowClient

    run_id = model.metadata.run_id
    if not run_id or _own_folder(model_uri):
        return ""
    try:
        run = MlflowClient(tracking_uri=tracking_uri).get_run(run_id)
    except MlflowException:  # gone for good: the model was loaded all the same (a registered version keeps its own)
        return f"the run that logged it ({run_id}) is no longer in {tracking_uri}"
    return f"the run that logged it ({run_id}) is deleted in {tracking_uri}" if run.info.lifecycle_stage == "deleted" else ""


def load_diagnosis_model(model_uri: str, tracking_uri: str):
    """The pyfunc model at ``model_uri`` (``models:/name@alias``, ``models:/name/version``, ``runs:/id/model``),
    its pipeline and the URI loaded: an alias replaced by the version it names now, for an alias moves (a sweep may
    move it while a diagnosis runs) and a verdict kept must say which model gave it. An unknown URI is a
    :class:`BearingTwinError` naming it."""
    import mlflow
    from mlflow.exceptions import MlflowException

    from bearingtwin.tracking.mlflow_logging import check_store, mlflow_reason

    if not _own_folder(model_uri):
        check_store(tracking_uri, must_exist=True)  # a server that does not answer, a store that is not there
    mlflow.set_tracking_uri(tracking_uri)
    registry = use_registry(tracking_uri)
    if model_uri.startswith("models:/") and registry != tracking_uri:
        check_store(registry, must_exist=True)
    try:
        version_uri = _version_named(model_uri, tracking_uri)
        # Into a folder of this process's own: from a local store MLflow would load a models:/ URI in place and write
        # its registered_model_meta into the store's artifacts, which a diagnosis must leave as they are (a team's
        # store may be read-only to its users).
        model = mlflow.pyfunc.load_model(version_uri, dst_path=_download_folder())
    except (MlflowException, OSError) as error:
        scheme = re.match(r"([A-Za-z][\w+.-]*):/", model_uri)
        if scheme and scheme[1] not in ("runs", "models") and not Path(model_uri).exists():  # modles:/, run:/
            raise BearingTwinError(f"model={model_uri}: {scheme[1]}:/ is no model URI here; give {MODEL_URI_FORMS}, "
                                   "or a model's folder") from None
        where = Path(model_uri)
        if scheme is None and not (where / "MLmodel").is_file():  # a path, or a bare name: MLflow speaks of a download
            what = ("a folder without an MLmodel file" if where.is_dir() else "a file, not a model's folder"
                    if where.exists() else "no such folder, nor a model URI")
            bare_name = not where.exists() and "/" not in model_uri  # sim2real for models:/sim2real@champion
            raise BearingTwinError(f"model={model_uri}: {what}; give {MODEL_URI_FORMS}, or a model's folder (one "
                                   "holding MLmodel)"
                                   + (_registry_words("models:/" + model_uri, tracking_uri) if bare_name else "")) from None
        raise BearingTwinError(f"model={model_uri}: cannot load it from {_store_of(model_uri, tracking_uri)} ({mlflow_reason(error)})"
                               f"{_unfinished_run_words(model_uri, tracking_uri)}"
                               f"{_registry_words(model_uri, tracking_uri)}") from None
    python_model = model.unwrap_python_model()
    if not isinstance(python_model, DiagnosisModel):
        raise BearingTwinError(f"model={model_uri}: not a bearingtwin diagnosis model ({type(python_model).__name__})")
    return model, python_model.pipeline, version_uri
