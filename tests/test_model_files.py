"""A fitted SVM saved as JSON + arrays predicts exactly as before, and a model file can construct
nothing but the SVM's own types."""

import json

import numpy as np
import pytest

from bearingtwin.errors import BearingTwinError
from bearingtwin.models.persistence import load_estimator, save_estimator
from bearingtwin.models.svm import SvmClassifier


@pytest.fixture(scope="module")
def fitted():
    rng = np.random.default_rng(0)
    y = np.repeat(np.arange(4), 30)
    X = rng.standard_normal((120, 9)) + y[:, None]
    return SvmClassifier(C=2.0, kernel="linear").fit(X, y), rng.standard_normal((40, 9)) * 2


def test_a_saved_svm_predicts_exactly_as_the_fitted_one(fitted, tmp_path):
    model, X = fitted
    assert save_estimator(model, tmp_path / "svm") == ["svm.json", "svm.npz"]
    loaded = load_estimator(tmp_path / "svm")
    assert type(loaded) is SvmClassifier and loaded.get_params() == model.get_params()
    np.testing.assert_array_equal(loaded.predict(X), model.predict(X))
    np.testing.assert_array_equal(loaded.predict_proba(X), model.predict_proba(X))
    np.testing.assert_array_equal(loaded.svm_.decision_function(X), model.svm_.decision_function(X))
    svc, loaded_svc = model.svm_[-1], loaded.svm_[-1]
    assert {name: type(value) for name, value in vars(loaded_svc).items()} == {name: type(value) for name, value in vars(svc).items()}


def test_a_model_file_naming_another_type_is_refused(fitted, tmp_path):
    model, _ = fitted
    save_estimator(model, tmp_path / "svm")
    structure = json.loads((tmp_path / "svm.json").read_text())
    structure["state"]["dict"]["svm_"]["object"] = "os.system"  # what a malicious file would ask for
    (tmp_path / "svm.json").write_text(json.dumps(structure))
    with pytest.raises(BearingTwinError, match=r"svm: names the type os.system, which a model file may not hold"):
        load_estimator(tmp_path / "svm")


def test_objects_outside_the_svm_are_not_saved_and_damaged_files_are_named(tmp_path):
    from sklearn.ensemble import RandomForestClassifier

    with pytest.raises(BearingTwinError, match="cannot save a sklearn.ensemble._forest.RandomForestClassifier"):
        save_estimator(RandomForestClassifier(), tmp_path / "forest")
    (tmp_path / "broken.json").write_text('{"object": ')
    np.savez(tmp_path / "broken.npz")
    with pytest.raises(BearingTwinError, match="broken: not a saved model"):
        load_estimator(tmp_path / "broken")


def test_an_svm_saved_in_skops_format_by_an_earlier_version_asks_for_training_again(tmp_path):
    from bearingtwin.diagnosis.pipeline import _load_classifier

    with pytest.raises(BearingTwinError, match="saved in skops' format by an earlier version.*train the model again"):
        _load_classifier({"kind": "svm", "file": "svm.skops"}, tmp_path)
