"""Feature extractors in scikit-learn style: SABO-tuned VMD features, and raw windows.

The paper's pipeline per window: decompose with VMD (k, alpha) found by SABO, keep the mode
with minimum envelope entropy, describe it by the nine time-domain features. Where the
(k, alpha) come from is the choice that decides whether the pipeline is a diagnosis:

* ``global`` (default): one search on the training set - the trial value is the fitness
  averaged over ``search_windows`` training windows drawn with ``seed`` - then every window
  is decomposed with those parameters. Needs no label at extraction time.
* ``per_class`` (the paper's Table 2): one search per label, each on ``search_windows``
  windows of that class drawn with ``seed``; a window is then decomposed with *its label's*
  parameters, so ``transform`` needs ``y``. A real diagnosis does not know the label of the
  window it diagnoses: the features carry the label through (k, alpha) and accuracies
  obtained this way are optimistic.
* ``per_sample``: every window gets its own search (expensive: N * (T + 1) decompositions
  per window, run in parallel with ``n_jobs``). Needs no label.
"""

from __future__ import annotations

import inspect

import numpy as np
from joblib import Parallel, delayed
from sklearn.base import BaseEstimator, TransformerMixin
from tqdm.auto import tqdm

from bearingtwin.checks import derived_seed, show_progress_bar, whole_number
from bearingtwin.errors import BearingTwinError
from bearingtwin.features.envelope_orders import EnvelopeOrderFeatures
from bearingtwin.features.fitness import FITNESS, optimal_mode, resolve_fitness
from bearingtwin.features.time_domain import FEATURE_NAMES, time_domain_features
from bearingtwin.optim.search import OPTIMIZERS, search_vmd_params, vmd_search_space
from bearingtwin.signal import vmd

VMD_PARAMS = ("global", "per_class", "per_sample")
# What ``vmd_options`` may set: vmd's keywords but the ones the extractor sets itself.
VMD_OPTIONS = frozenset(inspect.signature(vmd).parameters) - {"x", "k", "alpha", "seed", "return_n_iter"}
EXTRACTION_CHUNK = 256  # windows per VMD call: bounds memory at chunk * k * n * 8 bytes


def _check_windows(X) -> np.ndarray:
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2 or X.shape[0] == 0 or X.shape[1] < 2:
        raise BearingTwinError(f"X must be (n_windows, window_length) with at least one window, got shape {X.shape}")
    if not np.all(np.isfinite(X)):
        raise BearingTwinError("X holds NaN or infinite values")
    return X


def _check_labels(y, n: int, mode: str) -> np.ndarray:
    if y is None:
        raise BearingTwinError(f"vmd_params={mode!r} searches per label, so y (the labels) is required")
    y = np.asarray(y)
    if y.shape != (n,):
        raise BearingTwinError(f"y has shape {y.shape}, expected ({n},) labels for {n} windows")
    return y


class SaboVmdFeatures(TransformerMixin, BaseEstimator):
    """Nine time-domain features of the minimum-envelope-entropy mode of a SABO-tuned VMD.

    Args:
        fitness: ``pe_mie`` (the paper's) or ``min_envelope_entropy`` (its minEn variant).
        vmd_params: ``global``, ``per_class`` or ``per_sample`` (module docstring).
        optimizer: ``sabo``, ``tpe`` or ``cmaes`` (same budget: ``population * (iterations + 1)`` trials).
        population, iterations: SABO's N and T (paper: 15, 20).
        k_range, alpha_range: inclusive VMD search ranges (paper: [3, 10], [100, 3000]).
        search_windows: windows whose mean fitness scores a trial (``global``: drawn from the
            training set; ``per_class``: from each class). ``per_sample`` searches each window alone.
        fitness_params: keyword arguments of the fitness (e.g. ``pe_of``, ``w_pe``, ``pe_order``).
        vmd_options: keyword arguments of :func:`bearingtwin.signal.vmd` (``tol``, ``max_iter``, ...).
        seed: seeds window draws, searches and decompositions.
        n_jobs: parallel searches for ``per_sample`` (joblib).
        progress: show tqdm progress bars: True, False, or "auto" (in a terminal, outside CI).

    Fitted attributes:
        vmd_params_: list of dicts ``{scope, k, alpha, fitness, optimal_imf}``; scope is ``"global"``
            or the class label; ``optimal_imf`` is the 1-based index (as in the paper's Table 2)
            of the mode most often selected on the search windows.
    """

    def __init__(
        self,
        fitness: str = "pe_mie",
        vmd_params: str = "global",
        optimizer: str = "sabo",
        population: int = 15,
        iterations: int = 20,
        k_range: tuple[int, int] = (3, 10),
        alpha_range: tuple[float, float] = (100.0, 3000.0),
        search_windows: int = 8,
        fitness_params: dict | None = None,
        vmd_options: dict | None = None,
        seed: int = 0,
        n_jobs: int = 1,
        progress: bool | str = True,
    ) -> None:
        self.fitness = fitness
        self.vmd_params = vmd_params
        self.optimizer = optimizer
        self.population = population
        self.iterations = iterations
        self.k_range = k_range
        self.alpha_range = alpha_range
        self.search_windows = search_windows
        self.fitness_params = fitness_params
        self.vmd_options = vmd_options
        self.seed = seed
        self.n_jobs = n_jobs
        self.progress = progress

    def check_params(self) -> None:
        """Raise :class:`BearingTwinError` naming the first parameter with an impossible value."""
        # Named as the command line sets them (the optimizer is a top-level setting the features read).
        choices = {"fitness": ("features.fitness", tuple(FITNESS)), "vmd_params": ("features.vmd_params", VMD_PARAMS),
                   "optimizer": ("optimizer", OPTIMIZERS)}
        for name, (key, allowed) in choices.items():
            if getattr(self, name) not in allowed:
                raise BearingTwinError(f"{key}={getattr(self, name)!r} is not known; choose one of {', '.join(allowed)}")
        whole_number("search.windows", self.search_windows)  # features.search_windows is ${search.windows}
        whole_number("features.seed", self.seed, minimum=0)  # numpy's SeedSequence takes no negative seed
        # features.population is ${search.population}; SABO's agents learn from one another: it needs two (optim/sabo.py)
        whole_number("search.population", self.population, minimum=2 if self.optimizer == "sabo" else 1)
        whole_number("search.iterations", self.iterations)
        try:
            vmd_search_space(self.k_range, self.alpha_range)
        except BearingTwinError as error:
            raise BearingTwinError(f"features.{error}") from None
        unknown = sorted(set(self.vmd_options or {}) - VMD_OPTIONS)
        if unknown:
            raise BearingTwinError(f"features.vmd_options.{unknown[0]} is not an option of VMD; "
                                   f"known: {', '.join(sorted(VMD_OPTIONS))}")
        resolve_fitness(self.fitness, **dict(self.fitness_params or {}))
        show_progress_bar(self.progress, in_sweep=False, key="features.progress")

    def _check_length(self, X: np.ndarray) -> np.ndarray:
        """``X``, whose windows must give each of the most modes searched (``k_range``'s upper end) two bins of their
        one-sided spectrum at least: VMD splits that spectrum among its modes."""
        k_max = int(max(self.k_range))
        if X.shape[1] < 4 * k_max:
            raise BearingTwinError(f"windows of {X.shape[1]} samples are too short for VMD into up to {k_max} modes "
                                   f"(features.k_range): give data.window_length={4 * k_max} or more (the paper: 2048)")
        return X

    @property
    def shows_progress(self) -> bool:
        """Whether the bars show (``progress`` "auto": in a terminal, outside CI; a sweep's jobs have it false)."""
        return show_progress_bar(self.progress, in_sweep=False, key="features.progress")

    def fit(self, X, y=None) -> "SaboVmdFeatures":
        """Search the VMD parameters (``global``: once; ``per_class``: per label; ``per_sample``: nothing to fit)."""
        self.check_params()
        X = self._check_length(_check_windows(X))
        rng = np.random.default_rng(self.seed)
        if self.vmd_params == "global":
            self.vmd_params_ = [self._search_row("global", self._draw(X, rng), self.seed)]
        elif self.vmd_params == "per_class":
            y = _check_labels(y, len(X), self.vmd_params)
            self.vmd_params_ = [
                self._search_row(label.item(), self._draw(X[y == label], rng), derived_seed(self.seed, int(label)))
                for label in np.unique(y)
            ]
        else:
            self.vmd_params_ = []
        return self

    def transform(self, X, y=None) -> np.ndarray:
        """(n_windows, 9) features; ``y`` is needed (and only used) with ``vmd_params="per_class"``."""
        return self.extract(X, y)[0]

    def fit_transform(self, X, y=None, **fit_params) -> np.ndarray:
        return self.fit(X, y).transform(X, y)

    def extract(self, X, y=None) -> tuple[np.ndarray, list[dict]]:
        """Features and the VMD parameters they were computed with.

        Returns:
            features: (n_windows, 9), columns in :data:`~bearingtwin.features.time_domain.FEATURE_NAMES` order.
            rows: ``vmd_params_`` (``global`` / ``per_class``) or one row per window (``per_sample``,
                scope = window index).
        """
        if not hasattr(self, "vmd_params_"):
            raise BearingTwinError("SaboVmdFeatures: call fit before transform")
        X = self._check_length(_check_windows(X))
        if self.vmd_params == "per_sample":
            return self._extract_per_sample(X)
        features = np.empty((len(X), len(FEATURE_NAMES)))
        if self.vmd_params == "global":
            groups = [(np.arange(len(X)), self.vmd_params_[0])]
        else:
            y = _check_labels(y, len(X), self.vmd_params)
            by_label = {row["scope"]: row for row in self.vmd_params_}
            missing = sorted(set(np.unique(y).tolist()) - set(by_label))
            if missing:
                raise BearingTwinError(f"y holds label(s) {missing} that fit never saw; no VMD parameters for them")
            groups = [(np.flatnonzero(y == label), by_label[label]) for label in np.unique(y).tolist()]
        chunks = [
            (index[start : start + EXTRACTION_CHUNK], row)
            for index, row in groups
            for start in range(0, len(index), EXTRACTION_CHUNK)
        ]
        for index, row in tqdm(chunks, desc="VMD features", unit="chunk", disable=not self.shows_progress):
            features[index] = self._features(X[index], row["k"], row["alpha"])[0]
        return features, list(self.vmd_params_)

    def _draw(self, X: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        count = min(int(self.search_windows), len(X))
        return X[np.sort(rng.choice(len(X), size=count, replace=False))]

    def _search(self, windows: np.ndarray, seed: int):
        return search_vmd_params(
            windows,
            resolve_fitness(self.fitness, **dict(self.fitness_params or {})),
            optimizer=self.optimizer,
            population=self.population,
            iterations=self.iterations,
            k_range=tuple(self.k_range),
            alpha_range=tuple(self.alpha_range),
            seed=seed,
            vmd_options=dict(self.vmd_options or {}),
        )

    def _search_row(self, scope, windows: np.ndarray, seed: int) -> dict:
        result = self._search(windows, seed)
        _, selected = self._features(windows, result.k, result.alpha)
        return {
            "scope": scope,
            "k": result.k,
            "alpha": result.alpha,
            "fitness": result.value,
            "optimal_imf": int(np.bincount(selected).argmax()) + 1,
        }

    def _features(self, windows: np.ndarray, k: int, alpha: float) -> tuple[np.ndarray, np.ndarray]:
        """Features of the minimum-envelope-entropy mode of each window, and that mode's 0-based index."""
        modes, _ = vmd(windows, k, alpha, seed=self.seed, **dict(self.vmd_options or {}))
        selected = optimal_mode(modes)
        best = np.take_along_axis(modes, selected[:, None, None], axis=1)[:, 0, :]
        return time_domain_features(best), selected

    def _extract_per_sample(self, X: np.ndarray) -> tuple[np.ndarray, list[dict]]:
        def one(index: int) -> tuple[np.ndarray, dict]:
            row = self._search_row(index, X[index : index + 1], derived_seed(self.seed, index))
            return self._features(X[index : index + 1], row["k"], row["alpha"])[0][0], row

        jobs = Parallel(n_jobs=self.n_jobs, return_as="generator")(delayed(one)(i) for i in range(len(X)))
        results = list(tqdm(jobs, total=len(X), desc="per-sample SABO-VMD", unit="window", disable=not self.shows_progress))
        return np.stack([features for features, _ in results]), [row for _, row in results]


class RawFeatures(TransformerMixin, BaseEstimator):
    """The windows themselves, for a classifier that learns its own features (the paper's plain CNN-BiLSTM)."""

    def fit(self, X, y=None) -> "RawFeatures":
        _check_windows(X)
        self.vmd_params_: list[dict] = []
        return self

    def transform(self, X, y=None) -> np.ndarray:
        return _check_windows(X).copy()

    def extract(self, X, y=None) -> tuple[np.ndarray, list[dict]]:
        return self.transform(X), []


EXTRACTORS = {"sabo_vmd": SaboVmdFeatures, "raw": RawFeatures, "envelope_orders": EnvelopeOrderFeatures}


def build_feature_extractor(features_cfg) -> SaboVmdFeatures | RawFeatures | EnvelopeOrderFeatures:
    """The extractor a ``conf/features/*.yaml`` describes: ``kind`` picks the class, the other keys
    (except ``name``) are its parameters."""
    from omegaconf import DictConfig, OmegaConf

    cfg = OmegaConf.to_container(features_cfg, resolve=True) if isinstance(features_cfg, DictConfig) else dict(features_cfg)
    cfg.pop("name", None)
    kind = cfg.pop("kind", None)
    if kind not in EXTRACTORS:
        raise BearingTwinError(f"features.kind={kind!r} is not known; choose one of {', '.join(EXTRACTORS)}")
    cls = EXTRACTORS[kind]
    unknown = set(cfg) - set(cls().get_params())
    if unknown:
        raise BearingTwinError(f"features: unknown key(s) {sorted(unknown)} for kind {kind}")
    extractor = cls(**cfg)
    if hasattr(extractor, "check_params"):
        extractor.check_params()
    return extractor


def parameter_table(windows, labels, class_names=None, **params) -> list[dict]:
    """The paper's Table 2: one row per label with k, alpha, the fitness and the optimal IMF.

    Runs the ``per_class`` search (``params`` as for :class:`SaboVmdFeatures`). Labels are
    reported 1-based like the paper's (label 1 = class index 0).
    """
    extractor = SaboVmdFeatures(**{**params, "vmd_params": "per_class"}).fit(windows, labels)
    return [
        {
            "label": int(row["scope"]) + 1,
            **({"class": class_names[int(row["scope"])]} if class_names is not None else {}),
            "k": row["k"],
            "alpha": row["alpha"],
            "fitness": row["fitness"],
            "optimal_imf": row["optimal_imf"],
        }
        for row in extractor.vmd_params_
    ]
