"""classifier=sklearn: any scikit-learn classifier by its ``_target_``, checked before training, seeded by the run,
saved as a file that is read back without trusting anything outside scikit-learn, numpy and scipy; and the
settings of every classifier checked against what its class takes (a config file's typo named in one line)."""

import numpy as np
import pytest
import skops.io
from mlflow import MlflowClient
from omegaconf import OmegaConf
from processes import SMOKE, run_module
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import FunctionTransformer

from bearingtwin.diagnosis.pipeline import _load_classifier, _save_classifier
from bearingtwin.errors import BearingTwinError
from bearingtwin.models.build import build_classifier
from bearingtwin.models.sklearn_classifier import SklearnClassifier, make_estimator

FOREST = {"_target_": "sklearn.ensemble.RandomForestClassifier", "n_estimators": 20}
TRAINER = OmegaConf.create({"max_epochs": 2, "gradient_clip_val": 1.0, "accelerator": "cpu", "progress_bar": False})


def separable(seed: int = 0):
    """Three classes of windows' features, the second and third shifted apart from the first."""
    rng = np.random.default_rng(seed)
    y = np.repeat([0, 1, 3], 30)
    X = rng.normal(size=(y.size, 9)) + 2.0 * (y[:, None] == 1) - 2.0 * (y[:, None] == 3)
    return X, y


class Foreign:  # a type of neither scikit-learn, numpy nor scipy, as a model file must never hold
    def __call__(self, X):
        return X


@pytest.mark.parametrize("spec, said", [
    ({"_target_": "sklearn.linear_model.RidgeClassifier"},
     "gives no class probabilities (predict_proba), which a diagnosis reports; wrap it: "
     "classifier.estimator._target_=sklearn.calibration.CalibratedClassifierCV"),
    ({"_target_": "sklearn.ensemble.RandomForestClassifer"},
     "classifier.estimator._target_=sklearn.ensemble.RandomForestClassifer: Are you sure that "
     "'RandomForestClassifer' is importable from module 'sklearn.ensemble'? "
     "(did you mean sklearn.ensemble.RandomForestClassifier?)"),
    ({"_target_": "sklearn.ensemble.RandomForestClassifier", "n_estimator": 3},
     "unexpected keyword argument 'n_estimator' (did you mean classifier.estimator.n_estimators?)"),
    ({"_target_": "sklearn.ensemble.RandomForestClassifier", "n_estimators": -1},
     "classifier.estimator: The 'n_estimators' parameter of RandomForestClassifier must be an int in the range "
     "[1, inf). Got -1 instead."),
    ({"_target_": "sklearn.linear_model.Ridge"}, "sklearn.linear_model.Ridge is not a scikit-learn classifier"),
    ({"_target_": "collections.OrderedDict"}, "collections.OrderedDict is not a scikit-learn classifier"),
    ({"_target_": "sklearn.calibration.CalibratedClassifierCV",  # a wrapped estimator's bad value, before training
      "estimator": {"_target_": "sklearn.svm.LinearSVC", "C": -1}},
     "classifier.estimator: The 'C' parameter of LinearSVC must be a float in the range (0.0, inf). Got -1 instead."),
    ({"n_estimators": 3}, "classifier.estimator needs _target_"),
    # Hydra's refusal wraps over lines mid-sentence: its first line alone had ended "because it allows".
    ({"_target_": "os.system"}, "classifier.estimator (os.system): Target 'os.system' is blocklisted because it allows "
                                "config data to control executable behavior"),
])
def test_an_estimator_that_cannot_serve_a_diagnosis_is_refused_in_one_line(spec, said):
    with pytest.raises(BearingTwinError) as refused:
        make_estimator(spec, random_state=0)
    assert said in str(refused.value) and "\n" not in str(refused.value)


def test_the_runs_seed_fixes_a_random_estimator_and_an_explicit_one_is_kept():
    X, y = separable()
    same = [SklearnClassifier(FOREST, random_state=0).fit(X, y).predict_proba(X) for _ in range(2)]
    other = SklearnClassifier(FOREST, random_state=1).fit(X, y).predict_proba(X)
    assert np.array_equal(same[0], same[1]) and not np.array_equal(same[0], other)
    assert SklearnClassifier({**FOREST, "random_state": 7}, random_state=0).fit(X, y).model_[-1].random_state == 7
    # A wrapped estimator's draws too: the calibration's forest is seeded, so its probabilities repeat.
    wrapped = {"_target_": "sklearn.calibration.CalibratedClassifierCV", "estimator": FOREST}
    again = [SklearnClassifier(wrapped, random_state=0).fit(X, y).predict_proba(X) for _ in range(2)]
    assert np.array_equal(again[0], again[1])
    fitted = SklearnClassifier(FOREST).fit(X, y)
    assert list(fitted.classes_) == [0, 1, 3] and fitted.predict_proba(X).shape == (90, 3)
    assert (fitted.predict(X) == y).mean() > 0.9  # standardized, then the forest: the classes are apart


def test_a_setting_these_windows_cannot_meet_is_named_in_one_line():
    """More neighbours than training windows: scikit-learn's ValueError comes from the data, when neighbours are
    first asked for; it is said in one line naming the estimator and the windows, as every refusal of the data is
    (it had been a traceback)."""
    X, y = separable()
    knn = SklearnClassifier({"_target_": "sklearn.neighbors.KNeighborsClassifier", "n_neighbors": 100}).fit(X, y)
    with pytest.raises(BearingTwinError, match=r"^classifier\.estimator \(sklearn\.neighbors\.KNeighborsClassifier\)"
                                               r", fitted on 90 training windows: Expected n_neighbors <= "):
        knn.predict(X)


def test_a_saved_estimator_predicts_as_the_fitted_one_and_a_foreign_type_is_refused(tmp_path):
    X, y = separable()
    fitted = SklearnClassifier({"_target_": "sklearn.calibration.CalibratedClassifierCV",
                                "estimator": {"_target_": "sklearn.svm.LinearSVC"}}).fit(X, y)
    state = _save_classifier(fitted, tmp_path)
    loaded = _load_classifier(state, tmp_path)
    assert state["kind"] == "sklearn" and isinstance(loaded, SklearnClassifier)
    assert np.array_equal(loaded.predict_proba(X), fitted.predict_proba(X)) and list(loaded.classes_) == [0, 1, 3]

    # A file naming a type outside the trusted packages is refused before anything in it is built.
    skops.io.dump(Pipeline([("step", FunctionTransformer(Foreign()))]), tmp_path / "sklearn.skops")
    with pytest.raises(BearingTwinError, match=r"names the type .*Foreign, which a model file may not hold"):
        _load_classifier(state, tmp_path)


def test_a_classifier_fitted_on_state_names_saves_and_predicts_them(tmp_path):
    """Labels as a user's own table gives them ("ball", "outer"): save had cast every class to an int."""
    X, y = separable()
    names = np.array(["normal", "inner", "outer", "ball"])[y]
    fitted = SklearnClassifier().fit(X, names)
    loaded = _load_classifier(_save_classifier(fitted, tmp_path), tmp_path)
    assert list(loaded.classes_) == sorted(set(names)) and np.array_equal(loaded.predict(X), fitted.predict(X))


@pytest.mark.parametrize("classifier, trainer_key, said", [
    ({"name": "svm", "kernal": "linear"}, None, "classifier.kernal: not a setting of the svm classifier; "
                                                "did you mean classifier.kernel?"),
    ({"name": "svm", "n_filters": 8}, None, "classifier.n_filters: not a setting of the svm classifier; "
                                            "it takes C, kernel, gamma"),
    ({"name": "cnn_bilstm"}, "max_epoch", "trainer.max_epoch: not a setting of the cnn_bilstm classifier; "
                                          "did you mean trainer.max_epochs?"),
    ({"name": "cnn_bilstm", "max_epochs": 5}, None, "classifier.max_epochs: a trainer setting; give it as "
                                                    "trainer.max_epochs"),  # had been a TypeError: given twice
    ({"name": "cnn_bilstm"}, "foo", "trainer.foo: not a setting of the cnn_bilstm classifier; it takes gradient_clip_val, "
                                    "max_epochs, accelerator, progress_bar"),
    ({"name": "sklearn", "estimator": FOREST, "C": 1}, None, "classifier.C: not a setting of the sklearn "
                                                             "classifier; it takes estimator"),
    ({"name": "sklearn", "_target_": "sklearn.ensemble.RandomForestClassifier"}, None,
     "classifier._target_: the class of classifier=sklearn goes under classifier.estimator (estimator: {_target_: "
     "<module>.<class>, <argument>: <value>})"),
    ({"name": "random_forest", "_target_": "sklearn.ensemble.RandomForestClassifier"}, None,
     "classifier.name='random_forest' is not a classifier; choose one of cnn_bilstm, svm, sklearn (a scikit-learn "
     "class named by _target_ is classifier=sklearn's classifier.estimator)"),
])
def test_a_setting_the_classifier_does_not_take_is_named_with_the_closest_it_does(classifier, trainer_key, said):
    trainer = OmegaConf.merge(TRAINER, {trainer_key: 3} if trainer_key else {})
    with pytest.raises(BearingTwinError) as refused:
        build_classifier(OmegaConf.create(classifier), trainer, seed=0)
    assert str(refused.value) == said


def test_a_classifier_file_of_ones_own_trains_registers_and_diagnoses(tmp_path):
    """A user's conf/classifier file on hydra.searchpath (name: sklearn): trained, logged and registered, then
    diagnosing a twin record; a typo in such a file is refused in one line before a sweep opens any run."""
    own = tmp_path / "conf" / "classifier"
    own.mkdir(parents=True)
    (own / "forest.yaml").write_text("name: sklearn\nestimator:\n  _target_: sklearn.ensemble.RandomForestClassifier"
                                     "\n  n_estimators: 30\n")
    (own / "typo.yaml").write_text("name: svm\nkernal: linear\n")
    (own / "forest_typo.yaml").write_text("name: sklearn\nestimator:\n  _target_: sklearn.ensemble.RandomForestClassifier"
                                          "\n  n_estimator: 30\n")
    store = f"sqlite:///{tmp_path}/mlflow.db"
    search = f"hydra.searchpath=[file://{tmp_path / 'conf'}]"
    trained = run_module("bearingtwin.cli.train", *["classifier=forest", search, "register=forest",
                                                    f"tracking.uri={store}", *SMOKE], cwd=tmp_path)
    assert trained.returncode == 0, trained.stderr[-2000:]
    # Named and tagged by its estimator's class: every classifier=sklearn run had been "sklearn" alone.
    assert "== bearingtwin-train: sabo_vmd_pemie+forest RandomForestClassifier simulated global seed=0 ==" in trained.stdout
    (run,) = MlflowClient(store).search_runs([MlflowClient(store).get_experiment_by_name("bearingtwin").experiment_id])
    assert run.data.params["classifier.estimator.n_estimators"] == "30" and run.info.status == "FINISHED"
    assert run.data.tags["estimator"] == "sklearn.ensemble.RandomForestClassifier"

    simulated = run_module("bearingtwin.cli.simulate", *["fault=outer", "simulator.duration=1.0",
                                                        f"out={tmp_path / 'outer.npz'}"], cwd=tmp_path)
    assert simulated.returncode == 0, simulated.stderr[-2000:]
    diagnosed = run_module("bearingtwin.cli.diagnose", *[f"path={tmp_path / 'outer.npz'}", "model=models:/forest/1",
                                                        f"out={tmp_path / 'diagnosis'}", f"tracking.uri={store}"],
                           cwd=tmp_path)
    assert diagnosed.returncode == 0, diagnosed.stderr[-2000:]
    assert "records diagnosed: 1 of 1" in diagnosed.stdout

    swept = run_module("bearingtwin.cli.train", *["-m", "classifier=svm,typo", search,
                                                 f"tracking.uri=sqlite:///{tmp_path}/sweep.db", *SMOKE], cwd=tmp_path)
    assert swept.returncode == 2 and swept.stderr.strip().splitlines()[-1] == (
        "error: classifier.kernal: not a setting of the svm classifier; did you mean classifier.kernel?")
    assert not (tmp_path / "sweep.db").exists()
    # A typo among the estimator's own arguments too (it had failed its job, in a FAILED run, and the sweep exit 1).
    swept = run_module("bearingtwin.cli.train", *["-m", "classifier=forest,forest_typo", search,
                                                 f"tracking.uri=sqlite:///{tmp_path}/sweep.db", *SMOKE], cwd=tmp_path)
    assert swept.returncode == 2 and "(did you mean classifier.estimator.n_estimators?)" in swept.stderr
    assert not (tmp_path / "sweep.db").exists()
