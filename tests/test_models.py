"""The classifiers: the paper's CNN-BiLSTM (shape, optimizer, learning, determinism) and the SVM."""

import re
from pathlib import Path

import numpy as np
import pytest
import torch
from omegaconf import OmegaConf

from bearingtwin import PINS_CPU_KERNELS
from bearingtwin.config import CONF_DIR
from bearingtwin.errors import BearingTwinError
from bearingtwin.models.build import build_classifier
from bearingtwin.models.cnn_bilstm import CnnBiLstmClassifier, CnnBiLstmModule, CnnBiLstmShape
from bearingtwin.models.experiment import classification_scores
from bearingtwin.models.svm import SvmClassifier, make_svm
from bearingtwin.physics.geometry import FAULTS
from bearingtwin.tracking import paper


def four_blobs(n_per_class: int, n_features: int = 9, separation: float = 2.5, seed: int = 0):
    """Four classes whose nine 'features' differ in mean by ``separation`` standard deviations."""
    rng = np.random.default_rng(seed)
    labels = np.repeat(np.arange(4), n_per_class)
    centres = rng.normal(size=(4, n_features)) * separation
    return centres[labels] + rng.normal(size=(labels.size, n_features)), labels


def test_network_has_the_papers_layers_and_parameter_count():
    module = CnnBiLstmModule(CnnBiLstmShape(input_length=9))
    conv = 1 * 8 * 6 + 8
    batch_norm = 2 * 8
    bilstm = 2 * 4 * (30 * 8 + 30 * 30 + 2 * 30)  # two directions, four gates, two bias vectors
    fully_connected = 2 * 30 * 4 + 4
    assert sum(p.numel() for p in module.parameters()) == conv + batch_norm + bilstm + fully_connected
    # nine features -> conv (kernel 6) leaves 4 steps -> pool 2 leaves 2 BiLSTM steps
    assert module.shape.sequence_length == 2
    assert module(torch.zeros(5, 1, 9)).shape == (5, 4)
    flat = CnnBiLstmModule(CnnBiLstmShape(input_length=2048, lstm_output="flatten"))
    assert flat.shape.sequence_length == (2048 - 5) // 2
    assert flat.classify.in_features == 60 * flat.shape.sequence_length


def test_too_short_input_names_the_fields():
    with pytest.raises(BearingTwinError, match="kernel_size=6.*pool_size=2"):
        CnnBiLstmShape(input_length=6)
    with pytest.raises(BearingTwinError, match="lstm_output"):
        CnnBiLstmShape(input_length=9, lstm_output="mean")
    with pytest.raises(BearingTwinError, match="dropout"):
        CnnBiLstmShape(input_length=9, dropout=1.5)


def test_adam_weight_decay_equals_matlab_l2_loss_term_and_spares_biases():
    """MATLAB adds L2/2 * ||w||^2 to the loss for weights (BiasL2Factor 0, BN factors 1):
    one Adam step with our parameter groups equals one plain Adam step on that loss."""
    torch.manual_seed(0)
    x, y = torch.randn(16, 1, 9), torch.randint(0, 4, (16,))
    ours = CnnBiLstmModule(CnnBiLstmShape(input_length=9, dropout=0.0), l2_factor=0.05)
    reference = CnnBiLstmModule(CnnBiLstmShape(input_length=9, dropout=0.0))
    reference.load_state_dict(ours.state_dict())
    optimizer = ours.configure_optimizers()
    optimizer.zero_grad()
    ours.loss(ours(x), y).backward()
    optimizer.step()
    biases = {id(reference.features[0].bias), id(reference.classify.bias)}
    biases |= {id(p) for name, p in reference.bilstm.named_parameters() if name.startswith("bias")}
    penalised = [p for p in reference.parameters() if id(p) not in biases]
    plain = torch.optim.Adam(reference.parameters(), lr=0.01)
    plain.zero_grad()
    (reference.loss(reference(x), y) + 0.05 / 2 * sum((p**2).sum() for p in penalised)).backward()
    plain.step()
    for a, b in zip(ours.parameters(), reference.parameters()):
        torch.testing.assert_close(a, b)
    decayed_bn = ours.features[2].weight
    groups = {id(p): group["weight_decay"] for group in optimizer.param_groups for p in group["params"]}
    assert groups[id(ours.classify.bias)] == 0.0 and groups[id(decayed_bn)] == 0.05


def test_learns_separable_features_and_records_curves():
    X_all, y_all = four_blobs(90)
    test = np.arange(y_all.size) % 3 == 0
    X, y, X_test, y_test = X_all[~test], y_all[~test], X_all[test], y_all[test]
    classifier = CnnBiLstmClassifier(max_epochs=25, batch_size=32, random_state=0).fit(X, y, eval_set=(X_test, y_test))
    predicted = classifier.predict(X_test)
    assert np.mean(predicted == y_test) > 0.9
    history = classifier.history_
    assert len(history) == 25
    assert history[-1]["train_loss"] < 0.5 * history[0]["train_loss"]
    # the last epoch's validation pass sees the final weights, as predict does
    assert history[-1]["val_accuracy"] == pytest.approx(np.mean(predicted == y_test))
    np.testing.assert_allclose(classifier.predict_proba(X_test).sum(axis=1), 1.0, rtol=1e-6)


def test_standardization_uses_training_statistics_only():
    """A validation set on another scale leaves the scaler what the training windows make it."""
    X, y = four_blobs(20)
    train = X * 1000.0 + 50.0
    classifier = CnnBiLstmClassifier(max_epochs=1, random_state=0).fit(train, y, eval_set=(X * -300.0 + 7.0, y))
    np.testing.assert_allclose(classifier.scaler_.mean_, train.mean(axis=0))
    np.testing.assert_allclose(classifier.scaler_.scale_, train.std(axis=0))


def test_same_seed_same_model_other_seed_other_model():
    X, y = four_blobs(16)

    def probabilities(seed):
        return CnnBiLstmClassifier(max_epochs=3, batch_size=16, random_state=seed).fit(X, y).predict_proba(X)

    first = probabilities(3)
    np.testing.assert_array_equal(first, probabilities(3))
    assert not np.array_equal(first, probabilities(4))


def test_whole_numbers_written_as_floats_train_as_the_ints_they_are():
    """A sweep or a YAML may write 3.0 epochs, a batch of 16.0, 8.0 hidden units: Lightning asserted an int epoch
    count, torch's DataLoader and LSTM refused float sizes, each after the features were built. They are the
    ints they name: the model is the one the ints give."""
    X, y = four_blobs(16)
    whole = dict(max_epochs=3, batch_size=16, hidden_units=8, kernel_size=3, n_filters=4, pool_size=2)
    as_ints = CnnBiLstmClassifier(**whole).fit(X, y)
    as_floats = CnnBiLstmClassifier(**{name: float(value) for name, value in whole.items()}).fit(X, y)
    np.testing.assert_array_equal(as_floats.predict_proba(X), as_ints.predict_proba(X))
    assert as_floats.module_.shape == as_ints.module_.shape
    assert isinstance(as_floats.get_params()["max_epochs"], float)  # the parameter as given (scikit-learn's rule)


def test_the_same_seed_gives_the_same_model_on_any_number_of_cpu_threads():
    """A CPU result depends on how many threads split its reductions (here the probabilities differed by 7e-8
    between two threads and one, and the main job's accuracy by 1.1 points): training and prediction run on
    one thread whatever the machine, and restore the caller's count."""
    import torch

    rng = np.random.default_rng(0)
    y = np.repeat(np.arange(4), 32)
    X = np.sin(2 * np.pi * (y[:, None] + 1) * 4 * np.arange(512) / 512) + rng.normal(size=(128, 512))
    before = torch.get_num_threads()
    results = []
    try:
        for threads in (2, 1):
            torch.set_num_threads(threads)
            results.append(CnnBiLstmClassifier(max_epochs=2, batch_size=32, random_state=0).fit(X, y).predict_proba(X))
            assert torch.get_num_threads() == threads
    finally:
        torch.set_num_threads(before)
    np.testing.assert_array_equal(results[0], results[1])


def test_raw_windows_train_as_long_sequences():
    rng = np.random.default_rng(1)
    labels = np.repeat(np.arange(4), 4)
    t = np.arange(256)
    windows = np.sin(2 * np.pi * (labels[:, None] + 1) * 8 * t / 256) + 0.1 * rng.normal(size=(16, 256))
    classifier = CnnBiLstmClassifier(max_epochs=2, random_state=0).fit(windows, labels)
    assert classifier.module_.shape.sequence_length == (256 - 5) // 2
    probabilities = classifier.predict_proba(windows)
    assert probabilities.shape == (16, 4)
    np.testing.assert_allclose(probabilities.sum(axis=1), 1.0, rtol=1e-6)
    np.testing.assert_array_equal(classifier.predict(windows), classifier.classes_[probabilities.argmax(axis=1)])
    assert len(classifier.history_) == 2 and "val_loss" not in classifier.history_[0]


def test_bad_training_input_names_the_problem():
    X, y = four_blobs(4)
    with pytest.raises(BearingTwinError, match="labels have shape"):
        CnnBiLstmClassifier(max_epochs=1).fit(X, y[:-1])
    X[0, 0] = np.nan
    with pytest.raises(BearingTwinError, match="NaN"):
        CnnBiLstmClassifier(max_epochs=1).fit(X, y)
    with pytest.raises(BearingTwinError, match="trainer.max_epochs"):
        CnnBiLstmClassifier(max_epochs=0).fit(*four_blobs(4))


def test_svm_pipeline_learns_and_validates():
    X, y = four_blobs(40)
    svm = make_svm().fit(X[::2], y[::2])
    assert np.mean(svm.predict(X[1::2]) == y[1::2]) > 0.9
    with pytest.raises(BearingTwinError, match="classifier.C"):
        make_svm(C=0.0)
    with pytest.raises(BearingTwinError, match="classifier.kernel"):
        make_svm(kernel="cubic")


def test_an_svm_fit_that_stalls_with_shrinking_is_fitted_again_without_it(caplog):
    """libsvm's shrinking heuristic can cycle without end (a calibration fold of 11520 twin windows ran past 24
    minutes); stopped at MAX_ITER, that fit is done again without shrinking, and a fit that converges is kept
    as it is. Other warnings are not swallowed."""
    import warnings

    from sklearn.exceptions import ConvergenceWarning

    from bearingtwin.models.svm import MAX_ITER, converged

    calls = []

    def stalls_with_shrinking(shrinking):
        calls.append(shrinking)
        if shrinking:
            warnings.warn(f"Solver terminated early (max_iter={MAX_ITER})", ConvergenceWarning)
        return f"fitted, shrinking={shrinking}"

    with caplog.at_level("INFO", logger="bearingtwin.models.svm"):
        assert converged(stalls_with_shrinking) == "fitted, shrinking=False" and calls == [True, False]
    assert "stalled with shrinking" in caplog.text

    def converges_with_a_note(shrinking):
        calls.append(shrinking)
        warnings.warn("something else", UserWarning)
        return shrinking

    calls.clear()
    with pytest.warns(UserWarning, match="something else"):
        assert converged(converges_with_a_note) is True and calls == [True]
    X, y = four_blobs(40)
    svc = SvmClassifier().fit(X, y).svm_.named_steps["svc"]
    assert svc.shrinking and svc.max_iter == MAX_ITER and svc.fit_status_ == 0


def test_an_svm_stopped_at_its_iteration_cap_is_fitted_to_convergence_without_shrinking(monkeypatch):
    """Every fit of the classifier (the one that predicts, and the calibration's folds) stopped at the cap is done
    again without shrinking and without a cap, and converges to the same decisions."""
    import bearingtwin.models.svm as svm

    X, y = four_blobs(40)
    converged_first = SvmClassifier(kernel="linear").fit(X, y)
    monkeypatch.setattr(svm, "MAX_ITER", 3)
    refitted = SvmClassifier(kernel="linear").fit(X, y)
    for pipeline in (refitted.svm_, refitted.calibration_.calibrated_classifiers_[0].estimator):
        svc = pipeline.named_steps["svc"]
        assert not svc.shrinking and svc.max_iter == -1 and svc.fit_status_ == 0
    assert np.array_equal(refitted.predict(X), converged_first.predict(X))


@pytest.mark.parametrize("classifier", [SvmClassifier(), CnnBiLstmClassifier(max_epochs=1)], ids=["svm", "cnn_bilstm"])
def test_training_labels_of_one_state_are_refused_alike_by_both_classifiers(classifier):
    X, y = four_blobs(4)
    with pytest.raises(BearingTwinError, match=r"^the training windows are all of one bearing state \(outer\); "
                       r"a classifier needs at least 2"):
        classifier.fit(X[y == 3], y[y == 3])


def test_the_svm_names_the_state_with_too_few_windows_to_calibrate():
    X, y = four_blobs(4)
    keep = np.r_[np.flatnonzero(y != 2), np.flatnonzero(y == 2)[:1]]
    with pytest.raises(BearingTwinError, match=r"at least 2 training windows per class; class ball has 1"):
        SvmClassifier().fit(X[keep], y[keep])


def test_a_linear_svm_says_which_feature_each_pair_of_states_turns_on():
    """States told apart by one feature per pair (normal/inner by the first, normal/ball by the second; the
    third is noise): each pair's largest weight is on its feature, signed towards the first state of the pair
    when more of it means that state, with three states and with two."""
    rng = np.random.default_rng(0)
    y = np.repeat([0, 1, 2], 60)
    X = rng.normal(0.0, 0.3, (180, 3))
    X[:, 0] += np.where(y == 1, 2.0, 0.0)  # inner: more of the first feature
    X[:, 1] += np.where(y == 2, 6.0, 0.0)  # ball: much more of the second
    weights = SvmClassifier(kernel="linear").fit(X, y).pairwise_weights()
    assert list(weights) == [(0, 1), (0, 2), (1, 2)]
    assert np.argmax(np.abs(weights[(0, 1)])) == 0 and weights[(0, 1)][0] < 0  # more of feature 0: inner
    assert np.argmax(np.abs(weights[(0, 2)])) == 1 and weights[(0, 2)][1] < 0  # more of feature 1: ball
    assert np.argmax(np.abs(weights[(1, 2)])) == 1 and weights[(1, 2)][0] > 0  # feature 0 still pulls to inner
    assert all(abs(w[2]) < 0.5 * np.abs(w).max() for w in weights.values())  # the noise feature weighs little
    two = y < 2
    (pair, only), = SvmClassifier(kernel="linear").fit(X[two], y[two]).pairwise_weights().items()
    assert pair == (0, 1) and np.argmax(np.abs(only)) == 0 and only[0] < 0  # more of feature 0: inner, as above
    with pytest.raises(BearingTwinError, match="only a linear SVM has weights"):
        SvmClassifier(kernel="rbf").fit(X, y).pairwise_weights()


def test_build_from_the_config_files():
    trainer = OmegaConf.load(Path(CONF_DIR) / "trainer" / "default.yaml")
    network = build_classifier(OmegaConf.load(Path(CONF_DIR) / "classifier" / "cnn_bilstm.yaml"), trainer, seed=7)
    params = network.get_params()
    assert (params["n_filters"], params["kernel_size"], params["hidden_units"], params["dropout"]) == (8, 6, 30, 0.2)
    assert (params["learning_rate"], params["l2_factor"], params["gradient_clip_val"]) == (0.01, 0.001, 1.0)
    assert (params["max_epochs"], params["random_state"]) == (100, 7)
    svm = build_classifier(OmegaConf.load(Path(CONF_DIR) / "classifier" / "svm.yaml"), trainer, seed=7)
    assert (svm.C, svm.kernel, svm.gamma, svm.random_state) == (1.0, "rbf", "scale", 7)
    with pytest.raises(BearingTwinError, match="classifier.name='forest'"):
        build_classifier(OmegaConf.create({"name": "forest"}), trainer, seed=0)


@pytest.mark.parametrize("group, key, value, message", [
    ("svm", "C", "abc", "classifier.C must be a positive number, got 'abc'"),
    ("cnn_bilstm", "dropout", "abc", "classifier.dropout must be a number in [0, 1), got 'abc'"),
    ("cnn_bilstm", "n_filters", 0, "classifier.n_filters must be a positive integer, got 0"),
    ("cnn_bilstm", "learning_rate", 0.0, "classifier.learning_rate must be a positive number, got 0.0"),
    ("trainer", "max_epochs", "abc", "trainer.max_epochs must be a positive integer, got 'abc'"),
    ("trainer", "accelerator", "bogus", "trainer.accelerator='bogus' is not an accelerator Lightning knows; choose auto "
                                        "or one of gpu, cpu, cuda, mps, tpu"),
    # A sweep's job resolves only a valid progress_bar: a bad one fails that job here, in its run, not the sweep.
    ("trainer", "progress_bar", "maybe", "trainer.progress_bar must be auto, true or false, got 'maybe'"),
    ("trainer", "progress_bar", 1, "trainer.progress_bar must be auto, true or false, got 1"),  # 1 == True, no bool
])
def test_a_setting_of_the_wrong_kind_is_named_when_the_classifier_is_built(group, key, value, message):
    """A text where a number belongs failed inside fit (after the features) with a TypeError."""
    trainer = OmegaConf.load(Path(CONF_DIR) / "trainer" / "default.yaml")
    classifier = OmegaConf.load(Path(CONF_DIR) / "classifier" / f"{'cnn_bilstm' if group == 'trainer' else group}.yaml")
    OmegaConf.update(trainer if group == "trainer" else classifier, key, value)
    with pytest.raises(BearingTwinError) as error:
        build_classifier(classifier, trainer, seed=0)
    assert str(error.value) == message


@pytest.mark.skipif(torch.cuda.is_available() or torch.backends.mps.is_available(), reason="this machine has a GPU")
@pytest.mark.parametrize("accelerator", ["gpu", "cuda"])
def test_a_gpu_the_machine_lacks_is_named_when_the_classifier_is_built(accelerator):
    """Lightning refused it only inside fit, after the features were built, with a traceback."""
    trainer = OmegaConf.load(Path(CONF_DIR) / "trainer" / "default.yaml")
    OmegaConf.update(trainer, "accelerator", accelerator)
    classifier = OmegaConf.load(Path(CONF_DIR) / "classifier" / "cnn_bilstm.yaml")
    with pytest.raises(BearingTwinError, match=rf"^trainer.accelerator={accelerator}: this machine has no such device"):
        build_classifier(classifier, trainer, seed=0)


def test_scores_reproduce_the_form_of_table3():
    """15 test windows per class with one normal window called outer gives Table 3's figures."""
    y_true = np.repeat(np.arange(4), 15)
    y_pred = y_true.copy()
    y_pred[0] = FAULTS.index("outer")
    scores, confusion = classification_scores(y_true, y_pred, FAULTS)
    assert confusion[0, 3] == 1 and confusion.trace() == 59
    # abs 1e-3, not 5e-4: the paper's F1 0.965 is 2PR/(P+R) of the *rounded* P = 1, R = 0.933
    # (0.96534); from the exact R = 14/15 it is 0.96552.
    for name, published in paper.TABLE3.items():
        for metric, value in published.items():
            assert scores[f"{metric}_{name}"] == pytest.approx(value, abs=1e-3)
    assert scores["accuracy"] == pytest.approx(59 / 60)


def test_a_class_without_test_windows_is_given_no_recall_or_f1():
    """Fault records only (sim2real's test): the healthy class has no recall or F1 to report; a
    window called healthy still costs it precision, and a fault never called keeps its 0."""
    y_true = np.array([1, 1, 2, 2, 3, 3])
    y_pred = np.array([1, 0, 2, 2, 2, 2])
    scores, _ = classification_scores(y_true, y_pred, FAULTS)
    assert "recall_normal" not in scores and "f1_normal" not in scores
    assert scores["precision_normal"] == 0.0  # one window called healthy, wrongly
    assert scores["recall_inner"] == 0.5 and scores["f1_outer"] == 0.0 and scores["precision_outer"] == 0.0
    never_called, _ = classification_scores(y_true, y_true, FAULTS)
    assert not any(key.endswith("_normal") for key in never_called)


def test_the_epoch_progress_bar_goes_to_stderr_only_when_asked_for(capfd):
    """The bar shows the batch's loss, and the model is the one a silent fit makes."""
    X, y = four_blobs(8)
    shown_fit = CnnBiLstmClassifier(max_epochs=2, batch_size=16, progress_bar=True).fit(X, y, eval_set=(X, y))
    shown = capfd.readouterr()
    assert "Epoch 1" in shown.err and "Epoch" not in shown.out  # stdout is kept for a command's summary
    assert re.search(r"loss=\d\.\d{3}", shown.err)
    silent_fit = CnnBiLstmClassifier(max_epochs=2, batch_size=16).fit(X, y, eval_set=(X, y))
    np.testing.assert_array_equal(shown_fit.predict_proba(X), silent_fit.predict_proba(X))
    CnnBiLstmClassifier(max_epochs=2, batch_size=16, progress_bar="auto").fit(X, y)  # unresolved auto: silent
    assert "Epoch" not in capfd.readouterr().err


@pytest.mark.parametrize("classifier_name", ["svm", "cnn_bilstm"])
def test_band_power_is_kept_only_where_the_calibration_windows_bear_it_out(classifier_name):
    """Band power that separates the twin's classes but not the calibration records' (another rig's path
    and background) is dropped, with the extractor's feature; band power that holds on them is kept.
    Either classifier: the network is built afresh for the lines-only features, one input shorter."""
    from types import SimpleNamespace

    from bearingtwin.config import bearing_config
    from bearingtwin.features.envelope_orders import EnvelopeOrderFeatures
    from bearingtwin.models.experiment import FEATURE_GROUPS, choose_feature_group
    from bearingtwin.models.svm import SvmClassifier

    BAND_POWER = FEATURE_GROUPS[0]

    rng = np.random.default_rng(0)
    fs, rpm, n_train, n_val = 12000.0, 1797.0, 200, 40
    windows = rng.standard_normal((n_train + n_val, 4096))
    extractor = EnvelopeOrderFeatures(bearing=bearing_config("cwru_6205"), line_measure="prominence").fit(
        windows[:1], fs_hz=fs, rpm=rpm)
    n_lines = len(extractor.feature_names_) - 1
    labels = np.tile([0, 1], (n_train + n_val) // 2)
    lines = 0.8 * labels[:, None] * (np.arange(n_lines) == 0) + rng.normal(0.0, 0.3, (labels.size, n_lines))
    train, validation = np.arange(n_train), np.arange(n_train, n_train + n_val)
    dataset = SimpleNamespace(validation=validation, labels=labels, windows=windows, fs=fs,
                              window_rpms=np.full(labels.size, rpm))

    def fit(model, X):
        return model.fit(X[train], labels[train])

    def new_classifier():
        if classifier_name == "svm":
            return SvmClassifier(kernel="linear")
        return CnnBiLstmClassifier(max_epochs=15, batch_size=32, random_state=0)

    extractors = {}
    for shifted, kept in ((True, False), (False, True)):
        # In training the band power tells the classes apart at a glance; on the calibration windows of
        # another path it reads the same for both classes (shifted) or as in training.
        band_power = np.where(labels == 1, 0.0, -2.0) + rng.normal(0.0, 0.05, labels.size)
        band_power[validation] = -2.0 if shifted else band_power[validation]
        features = np.column_stack([lines, band_power])
        with_it = fit(new_classifier(), features)
        classifier, chosen, chosen_extractor, scores = choose_feature_group(
            BAND_POWER, with_it, features, extractor, dataset, train, fit, new_classifier)
        assert scores["band_power_kept"] == float(kept)
        assert (scores["band_power_calibration_accuracy"] >= scores["lines_only_calibration_accuracy"]) == kept
        assert chosen.shape[1] == n_lines + kept and chosen_extractor.band_power == kept
        assert len(chosen_extractor.feature_names_) == chosen.shape[1]
        assert (classifier is with_it) == kept
        assert chosen_extractor.transform(windows[:2], fs_hz=fs, rpm=rpm).shape == (2, chosen.shape[1])
        extractors[kept] = chosen_extractor
    with pytest.raises(BearingTwinError, match="band_power_by_calibration: the features have no band power"):
        choose_feature_group(BAND_POWER, with_it, lines, extractors[False], dataset, train, fit, new_classifier)
    with pytest.raises(BearingTwinError, match="no calibration windows to choose on"):
        choose_feature_group(BAND_POWER, with_it, features, extractor, SimpleNamespace(**{**vars(dataset), "validation": []}),
                          train, fit, new_classifier)


def test_cage_rate_lines_that_do_not_hold_on_the_calibration_records_are_dropped_with_the_extractors_rate():
    """Cage-rate (FTF) lines that tell the twin's classes apart but not the calibration records' (a path that hears
    a defect carried round otherwise) are dropped: the classifier refitted without them, the extractor reading
    the other rates only; lines that hold are kept. Chosen after the band power, on what that choice left."""
    from types import SimpleNamespace

    from bearingtwin.config import bearing_config
    from bearingtwin.features.envelope_orders import EnvelopeOrderFeatures
    from bearingtwin.models.experiment import FEATURE_GROUPS, choose_feature_group
    from bearingtwin.models.svm import SvmClassifier

    cage_lines = FEATURE_GROUPS[1]
    rng = np.random.default_rng(1)
    fs, rpm, n_train, n_val = 12000.0, 1797.0, 200, 40
    windows = rng.standard_normal((n_train + n_val, 4096))
    extractor = EnvelopeOrderFeatures(bearing=bearing_config("cwru_6205"), line_measure="prominence",
                                      band_power=False).fit(windows[:1], fs_hz=fs, rpm=rpm)
    cage = np.array([name.endswith("xftf") for name in extractor.feature_names_])
    labels = np.tile([0, 1], (n_train + n_val) // 2)
    train, validation = np.arange(n_train), np.arange(n_train, n_train + n_val)
    dataset = SimpleNamespace(validation=validation, labels=labels, windows=windows, fs=fs,
                              window_rpms=np.full(labels.size, rpm))

    def fit(model, X):
        return model.fit(X[train], labels[train])

    for shifted, kept in ((True, False), (False, True)):
        features = 0.6 * labels[:, None] * (np.arange(cage.size) == 0) + rng.normal(0.0, 0.3, (labels.size, cage.size))
        features[:, cage] = np.where(labels == 1, 1.0, 0.0)[:, None] + rng.normal(0.0, 0.05, (labels.size, cage.sum()))
        if shifted:  # on the calibration windows the cage lines read the other way round
            features[np.ix_(validation, cage)] = 1.0 - features[np.ix_(validation, cage)]
        with_them = fit(SvmClassifier(kernel="linear"), features)
        classifier, chosen, chosen_extractor, scores = choose_feature_group(
            cage_lines, with_them, features, extractor, dataset, train, fit, lambda: SvmClassifier(kernel="linear"))
        assert scores["cage_lines_kept"] == float(kept), scores
        assert chosen.shape[1] == cage.size - (0 if kept else cage.sum())
        assert ("ftf" in chosen_extractor.rates) == kept and (classifier is with_them) == kept
        assert chosen_extractor.transform(windows[:2], fs_hz=fs, rpm=rpm).shape == (2, chosen.shape[1])
    with pytest.raises(BearingTwinError, match=r"cage_lines_by_calibration: the features have no cage-rate lines"):
        choose_feature_group(cage_lines, with_them, chosen, chosen_extractor.set_params(rates=["bpfo", "bsf2"]),
                             dataset, train, fit, lambda: SvmClassifier(kernel="linear"))


def test_a_band_power_choice_with_nothing_to_choose_is_refused_before_any_data_is_built(monkeypatch):
    from bearingtwin.config import compose_config
    from bearingtwin.models import experiment

    def no_data(cfg):
        raise AssertionError("the data were built before the settings were checked")

    monkeypatch.setattr(experiment, "build_dataset", no_data)
    for key, words in (("band_power_by_calibration", "band power"), ("cage_lines_by_calibration", "cage-rate lines")):
        for overrides, message in ((["classifier=svm", "features=envelope_prominence"], "no calibration windows to choose on"),
                                   (["classifier=svm", "data=twin_to_real", "bearing=cwru_6205"], f"features have no {words}")):
            cfg = compose_config("train", [*overrides, f"{key}=true"])
            with pytest.raises(BearingTwinError, match=f"{key}: .*{message}"):
                experiment.run_experiment(cfg)


@pytest.mark.parametrize("data, bearing", [("cwru", "cwru_6205"), ("hust", "er16k")])
def test_defect_order_features_of_another_bearing_than_the_datas_are_refused_before_any_data_is_built(monkeypatch, data,
                                                                                                      bearing):
    """Features read at the twin's default bearing's orders on records of another bearing would read lines where
    the recorded bearing has none; given the data's bearing, the same run goes on to build its data."""
    from bearingtwin.config import compose_config
    from bearingtwin.models import experiment

    class Built(Exception):
        pass

    def built(cfg):
        raise Built

    monkeypatch.setattr(experiment, "build_dataset", built)
    cfg = compose_config("train", [f"data={data}", "features=envelope_orders", "classifier=svm"])
    with pytest.raises(BearingTwinError, match=f"features.bearing is paper, .* is {bearing}: .* add bearing={bearing} if "
                                               f"the records are of {bearing}, data.bearing=paper if they are of paper"):
        experiment.run_experiment(cfg)
    with pytest.raises(Built):
        experiment.run_experiment(compose_config("train", [f"data={data}", "features=envelope_orders", "classifier=svm",
                                                           f"bearing={bearing}"]))
    # A data.bearing no config describes is named as such, not as a mismatch to be mended by bearing=<it>.
    with pytest.raises(BearingTwinError, match=r"^data.bearing=my_typo: no such bearing config; choose one of"):
        experiment.run_experiment(compose_config("train", [f"data={data}", "features=envelope_orders", "classifier=svm",
                                                           "data.bearing=my_typo"]))


def test_physics_first_settings_are_checked_before_any_data_and_data_without_speeds_before_any_features(monkeypatch):
    """A malformed physics_first is named before the data are built; data that state no shaft speed (the twin's
    own simulated windows) are refused right after, before the features' minutes."""
    from bearingtwin.config import compose_config
    from bearingtwin.data.recording import WindowedDataset
    from bearingtwin.models import experiment

    def no_data(cfg):
        raise AssertionError("the data were built before the settings were checked")

    monkeypatch.setattr(experiment, "build_dataset", no_data)
    for override, message in (("physics_first=20", r"physics_first must be null or \{threshold_db"),
                              ("physics_first={threshold_db:20,margin:10}", "physics_first.margin is not a setting"),
                              ("physics_first={threshold_db:25}", "physics_first.margin_db is missing; give both"),
                              ("physics_first={threshold_db:-3,margin_db:10}", "physics_first.threshold_db must be a non-negative")):
        cfg = compose_config("train", ["classifier=svm", "features=envelope_prominence", override])
        with pytest.raises(BearingTwinError, match=message):
            experiment.run_experiment(cfg)

    def no_speeds(cfg):
        return WindowedDataset(windows=np.zeros((2, 2048)), labels=np.array([0, 1]), record_ids=np.array([0, 1]),
                               starts=np.zeros(2, dtype=int), records=["a", "b"], fs=12000.0, class_names=["normal", "inner"],
                               key="none")

    monkeypatch.setattr(experiment, "build_dataset", no_speeds)
    monkeypatch.setattr(experiment, "extract_features", lambda *args: pytest.fail("features extracted"))
    cfg = compose_config("train", ["classifier=svm", "physics_first={threshold_db:20,margin_db:10}"])
    with pytest.raises(BearingTwinError, match="physics_first reads each window at its shaft speed; this data states none"):
        experiment.run_experiment(cfg)


def test_a_validation_label_the_network_was_not_trained_on_is_named():
    """searchsorted would score a label between two trained ones as a neighbour, silently."""
    X, y = four_blobs(8)
    keep = y != 2
    with pytest.raises(BearingTwinError, match=r"^eval_set holds label\(s\) \[2\] that y does not"):
        CnnBiLstmClassifier(max_epochs=1, batch_size=16).fit(X[keep], y[keep], eval_set=(X, y))


def test_a_fit_prints_no_warning_of_lightnings_own_use_of_torch():
    """Lightning 2.6 calls a torch API that torch 2.13 deprecates (LeafSpec) at every fit: noise a user cannot act on."""
    import warnings

    X, y = four_blobs(4)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        CnnBiLstmClassifier(max_epochs=1, random_state=0).fit(X, y)
    assert not [w for w in caught if "LeafSpec" in str(w.message)], [str(w.message) for w in caught]


_FIT_IN_A_FRESH_PROCESS = """
import json, sys
import numpy as np
import bearingtwin
import torch
from bearingtwin.models.cnn_bilstm import CnnBiLstmClassifier
rng = np.random.default_rng(0)
y = np.repeat(np.arange(4), 16)
X = np.sin(2 * np.pi * (y[:, None] + 1) * 4 * np.arange(256) / 256) + rng.normal(size=(64, 256))
probabilities = CnnBiLstmClassifier(max_epochs=2, batch_size=16, random_state=0).fit(X, y).predict_proba(X)
print(json.dumps({"capability": torch.backends.cpu.get_cpu_capability(), "probabilities": probabilities.tolist()}))
"""


@pytest.mark.skipif(not PINS_CPU_KERNELS, reason="the pinned kernels are x86's")
def test_the_same_seed_gives_the_same_model_whatever_instruction_sets_the_machine_offers():
    """Importing bearingtwin pins torch's and MKL's CPU kernels before they load: a process that MKL treats as an
    AVX2-only machine trains the same model as one that may use every instruction set here. A kernel choice the
    environment makes itself is kept."""
    import json
    import os
    import subprocess
    import sys

    from bearingtwin import PINNED_CPU_KERNELS

    unpinned = {name: value for name, value in os.environ.items() if name not in PINNED_CPU_KERNELS}

    def fit(**env):
        done = subprocess.run([sys.executable, "-c", _FIT_IN_A_FRESH_PROCESS], capture_output=True, text=True,
                              env={**unpinned, **env}, timeout=600, check=True)
        return json.loads(done.stdout.strip().splitlines()[-1])

    here, avx2_only = fit(), fit(MKL_ENABLE_INSTRUCTIONS="AVX2")
    assert here["capability"] == avx2_only["capability"] == "DEFAULT"
    assert here["probabilities"] == avx2_only["probabilities"]
    assert fit(ATEN_CPU_CAPABILITY="avx2")["capability"] == "AVX2"


@pytest.mark.skipif(not PINS_CPU_KERNELS, reason="the pinned kernels are x86's")
def test_torch_that_chose_its_kernels_before_bearingtwin_is_warned_of_and_recorded_as_it_runs():
    """A script that runs a torch operation before importing bearingtwin has the machine's kernels for good: the
    import says so, and the kernels a run records are torch's own, not the pin it could not apply. Imported
    first, bearingtwin pins them and says nothing."""
    import os
    import subprocess
    import sys

    from bearingtwin import PINNED_CPU_KERNELS

    unpinned = {name: value for name, value in os.environ.items() if name not in PINNED_CPU_KERNELS}
    script = ("import torch; torch.ones(2).sum(); import bearingtwin; "
              "print(torch.backends.cpu.get_cpu_capability().lower(), bearingtwin.cpu_kernels())")
    late = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=unpinned, timeout=120,
                          check=True)
    used, recorded = late.stdout.split(" ", 1)
    assert recorded.startswith(f"ATEN_CPU_CAPABILITY={used},")
    assert ("import bearingtwin before torch" in late.stderr) == (used != "default")
    early = subprocess.run([sys.executable, "-c", "import bearingtwin, torch; torch.ones(2).sum(); "
                            "print(bearingtwin.cpu_kernels())"], capture_output=True, text=True, env=unpinned,
                           timeout=120, check=True)
    assert early.stdout.startswith("ATEN_CPU_CAPABILITY=default,") and "bearingtwin before torch" not in early.stderr
