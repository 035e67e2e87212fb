"""SABO as an Optuna sampler: exact agreement with Algorithm 1, convergence, reproducibility."""

import numpy as np
import optuna
import pytest
from optuna.distributions import CategoricalDistribution, FloatDistribution, IntDistribution

from bearingtwin.errors import BearingTwinError
from bearingtwin.optim.sabo import SaboSampler
from bearingtwin.optim.search import OPTIMIZERS, make_sampler, minimize, vmd_search_space

CENTRE = np.array([1.5, -2.0])


def shifted_sphere(x):
    return float(np.sum((np.asarray(x, dtype=float) - CENTRE) ** 2))


def reference_sabo(fitness, low, high, population, iterations, seed, integer=()):
    """Algorithm 1 of Ma & Zhu (2025) in plain loops: the oracle the sampler must match.

    Integer dimensions keep continuous positions and are rounded only for evaluation.
    Returns every evaluated (position, value) in order.
    """
    rng = np.random.default_rng(seed)
    low, high = np.asarray(low, float), np.asarray(high, float)
    m = low.size

    def evaluate(position):
        point = position.copy()
        for d in integer:
            point[d] = np.round(point[d])
        return fitness(point)

    X = low + rng.random((population, m)) * (high - low)
    score = np.array([evaluate(x) for x in X])
    history = [(x.copy(), s) for x, s in zip(X, score)]
    for _ in range(iterations):
        for i in range(population):
            DX = np.zeros(m)
            for j in range(population):
                I = np.round(1 + rng.random() + rng.random())
                for d in range(m):
                    DX[d] = DX[d] + (X[j, d] - I * X[i, d]) * np.sign(score[i] - score[j])
            r = rng.random(m)
            X_new = np.clip(X[i] + (r * DX) / population, low, high)
            score_new = evaluate(X_new)
            history.append((X_new.copy(), score_new))
            if score_new < score[i]:
                X[i] = X_new
                score[i] = score_new
    return history


def run(search_space, objective, optimizer="sabo", population=15, iterations=20, seed=0):
    names = list(search_space)
    return minimize(
        lambda params: [objective(np.array([p[name] for name in names], dtype=float)) for p in params],
        search_space,
        optimizer=optimizer,
        population=population,
        iterations=iterations,
        seed=seed,
    )


def test_sampler_follows_algorithm_1_exactly_on_a_shifted_sphere():
    space = {"x": FloatDistribution(-5.0, 5.0), "y": FloatDistribution(-5.0, 5.0)}
    study = run(space, shifted_sphere, population=8, iterations=6, seed=3)
    expected = reference_sabo(shifted_sphere, [-5, -5], [5, 5], 8, 6, seed=3)
    trials = study.trials
    assert len(trials) == len(expected) == 8 * 7
    for trial, (position, value) in zip(trials, expected):
        np.testing.assert_array_equal(trial.system_attrs["sabo:position"], position)
        assert trial.value == value


def test_integer_dimension_keeps_a_continuous_position_and_is_rounded_for_evaluation():
    space = vmd_search_space((3, 10), (100, 3000))

    def bowl(point):
        return (point[0] - 6) ** 2 + ((point[1] - 1200) / 300) ** 2

    study = run(space, bowl, population=6, iterations=5, seed=11)
    expected = reference_sabo(bowl, [3, 100], [10, 3000], 6, 5, seed=11, integer=(0,))
    positions = np.array([t.system_attrs["sabo:position"] for t in study.trials])
    np.testing.assert_array_equal(positions, [p for p, _ in expected])
    assert [t.value for t in study.trials] == [v for _, v in expected]
    ks = np.array([t.params["k"] for t in study.trials])
    assert all(isinstance(t.params["k"], int) for t in study.trials)
    np.testing.assert_array_equal(ks, np.round(positions[:, 0]))
    assert np.any(positions[:, 0] != np.round(positions[:, 0]))


@pytest.mark.parametrize(
    "objective, minimum",
    [
        (shifted_sphere, CENTRE),
        # Booth's function: a tilted valley with its minimum 0 at (1, 3).
        (lambda p: (p[0] + 2 * p[1] - 7) ** 2 + (2 * p[0] + p[1] - 5) ** 2, np.array([1.0, 3.0])),
    ],
)
def test_sabo_finds_the_minimum_of_2d_functions(objective, minimum):
    """Paper budget (N = 15, T = 20): within 2.5 % of the range of the minimum, 10x below the best random start."""
    width = 20.0
    space = {"x": FloatDistribution(-width / 2, width / 2), "y": FloatDistribution(-width / 2, width / 2)}
    for seed in range(3):
        study = run(space, objective, population=15, iterations=20, seed=seed)
        best = np.array([study.best_params["x"], study.best_params["y"]])
        assert np.linalg.norm(best - minimum) < 0.025 * width
        assert study.best_value < 0.1 * min(t.value for t in study.trials[:15])


def test_same_seed_gives_identical_trials_and_another_seed_does_not():
    space = {"x": FloatDistribution(-5.0, 5.0), "y": FloatDistribution(-5.0, 5.0)}
    first, again, other = (run(space, shifted_sphere, population=6, iterations=3, seed=s) for s in (7, 7, 8))
    assert [t.params for t in first.trials] == [t.params for t in again.trials]
    assert [t.params for t in first.trials] != [t.params for t in other.trials]


@pytest.mark.parametrize("optimizer", OPTIMIZERS)
def test_every_optimizer_is_selectable_spends_the_same_budget_and_improves_on_random(optimizer):
    space = {"x": FloatDistribution(-5.0, 5.0), "y": FloatDistribution(-5.0, 5.0)}
    study = run(space, shifted_sphere, optimizer=optimizer, population=10, iterations=9, seed=1)
    assert len(study.trials) == 10 * 10
    assert type(study.sampler) is type(make_sampler(optimizer, space, 10, 1))
    initial_best = min(t.value for t in study.trials[:10])
    assert study.best_value < initial_best
    assert study.best_value < 0.5


def test_the_initial_population_is_offered_as_one_batch_then_moves_one_at_a_time():
    space = {"x": FloatDistribution(-5.0, 5.0)}
    batches = []

    def evaluate(params):
        batches.append(len(params))
        return [(p["x"] - 1) ** 2 for p in params]

    minimize(evaluate, space, population=5, iterations=2, seed=0)
    assert batches == [5] + [1] * 10


def test_asking_the_next_move_before_telling_the_last_is_refused():
    space = {"x": FloatDistribution(-5.0, 5.0)}
    sampler = SaboSampler(space, population=3, seed=0)
    study = optuna.create_study(sampler=sampler)
    for trial in [study.ask(space) for _ in range(3)]:
        study.tell(trial, trial.params["x"] ** 2)
    study.ask(space)
    with pytest.raises(BearingTwinError, match="sequential"):
        study.ask(space)


@pytest.mark.filterwarnings("ignore:The value nan is not acceptable")
def test_failed_trials_score_infinity_and_agents_leave_them():
    space = {"x": FloatDistribution(-5.0, 5.0)}
    study = minimize(
        lambda params: [np.nan if p["x"] > 0 else p["x"] ** 2 for p in params], space, population=6, iterations=6
    )
    states = [t.state for t in study.trials]
    assert optuna.trial.TrialState.FAIL in states[:6]
    scores, positions = study.sampler.scores, study.sampler.positions[:, 0]
    assert np.all(np.isfinite(scores)) and np.all(positions <= 0)
    assert study.best_params["x"] <= 0


def test_bad_search_spaces_and_optimizers_name_the_culprit():
    with pytest.raises(BearingTwinError, match="search_space.kind"):
        SaboSampler({"kind": CategoricalDistribution(["a", "b"])})
    with pytest.raises(BearingTwinError, match="optimizer='annealing'"):
        make_sampler("annealing", {"x": FloatDistribution(0, 1)}, 5, 0)
    with pytest.raises(BearingTwinError, match="k_range"):
        vmd_search_space((10, 3), (100, 3000))
    with pytest.raises(BearingTwinError, match="alpha_range"):
        vmd_search_space((3, 10), (100,))
    with pytest.raises(BearingTwinError, match="population"):
        SaboSampler({"x": IntDistribution(0, 4)}, population=1)


def test_a_sabo_study_in_sqlite_storage_holds_the_same_trials(tmp_path):
    space = {"x": FloatDistribution(-5.0, 5.0), "y": FloatDistribution(-5.0, 5.0)}
    storage = f"sqlite:///{tmp_path / 'sabo.db'}"
    stored = optuna.create_study(storage=storage, study_name="sphere", sampler=SaboSampler(space, population=5, seed=4))
    minimize(lambda ps: [shifted_sphere([p["x"], p["y"]]) for p in ps], space, population=5, iterations=2, study=stored)
    loaded = optuna.load_study(study_name="sphere", storage=storage)
    in_memory = run(space, shifted_sphere, population=5, iterations=2, seed=4)
    assert [(t.params, t.value) for t in loaded.trials] == [(t.params, t.value) for t in in_memory.trials]
    assert [t.system_attrs["sabo:agent"] for t in loaded.trials] == [0, 1, 2, 3, 4] * 3
