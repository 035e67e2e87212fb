"""Extract a dataset's features once per configuration, safely from parallel sweep jobs.

A SABO-VMD extraction costs minutes to hours (``per_sample``: one search per window), and
five training seeds or a sweep over classifiers reuse it. The cache file is named by a hash
of what determines the numbers: the dataset key, the feature config (without ``n_jobs`` and
``progress``, which do not change them) and, when the extractor is fitted on the training
windows (``global``, ``per_class``), the training indices. It is written to a temporary file
and moved into place with ``os.replace``, so concurrent jobs never read half a file; two jobs
missing at once both compute and the second replace is harmless. An entry that cannot be
read is removed and recomputed (:func:`~bearingtwin.storage.load_npz_or_heal`).
"""

from __future__ import annotations

import hashlib
import json
import logging
from pathlib import Path

import numpy as np

from bearingtwin.data.recording import WindowedDataset
from bearingtwin.errors import BearingTwinError
from bearingtwin.features import NOT_AFFECTING_NUMBERS
from bearingtwin.storage import FEATURE_CODE, code_fingerprint, content_key, load_npz_or_heal, save_npz_atomic
from bearingtwin.features.extractor import EnvelopeOrderFeatures, RawFeatures, build_feature_extractor

log = logging.getLogger(__name__)

CACHE_FORMAT = 1  # bump when the stored layout or the extraction's numbers change


def _config_dict(features_cfg) -> dict:
    from omegaconf import DictConfig, OmegaConf

    if isinstance(features_cfg, DictConfig):
        return OmegaConf.to_container(features_cfg, resolve=True)
    return dict(features_cfg)


def _dataset_key(dataset: WindowedDataset) -> str:
    """The dataset's declared key, or a hash of its windows and labels when it has none."""
    if dataset.key:
        return dataset.key
    digest = hashlib.sha256(np.ascontiguousarray(dataset.windows).tobytes())
    digest.update(np.ascontiguousarray(dataset.labels).tobytes())
    return "content-" + digest.hexdigest()


def cache_path(features_cfg, dataset: WindowedDataset, train_index, cache_dir) -> Path:
    """Where the extraction for this configuration, dataset and training split is stored."""
    cfg = _config_dict(features_cfg)
    uses_training_set = cfg.get("kind") == "sabo_vmd" and cfg.get("vmd_params", "global") in ("global", "per_class")
    material = {
        "format": CACHE_FORMAT,
        "code": code_fingerprint(*FEATURE_CODE),  # an extraction by other code is another
        "dataset": _dataset_key(dataset),
        "features": {key: value for key, value in cfg.items() if key not in NOT_AFFECTING_NUMBERS},
        "train": hashlib.sha256(np.sort(np.asarray(train_index, dtype=np.int64)).tobytes()).hexdigest()
        if uses_training_set
        else None,
    }
    return Path(cache_dir) / "features" / f"{cfg.get('name', 'features')}-{content_key(material, 20)}.npz"


def extract_features(features_cfg, dataset: WindowedDataset, train_index, cache_dir) -> tuple[np.ndarray, list[dict], object]:
    """Features of every window of ``dataset``, fitted on ``train_index``; cached.

    Args:
        features_cfg: the ``features`` config group (``conf/features/*.yaml``) or an equivalent dict.
        dataset: all windows; the extractor is fitted on ``dataset.windows[train_index]`` (with their
            labels) and applied to every window. With ``vmd_params=per_class`` every window's own
            label chooses its parameters, test windows included - the paper's protocol.
        train_index: indices of the training windows.
        cache_dir: root of the cache (``paths.cache_dir``); files go to ``<cache_dir>/features/``.

    Returns:
        features: (n_windows, 9) for SABO-VMD features; the windows themselves (not cached) for ``raw``;
            envelope-order fractions (not cached, need ``dataset.record_rpms``) for ``envelope_orders``.
        table: the VMD parameters used (rows as in :attr:`SaboVmdFeatures.vmd_params_`).
        extractor: the fitted extractor, ready to transform new windows as these were (on a cache
            hit its fitted state is restored from the stored table): the feature path a diagnosis reuses.
    """
    extractor = build_feature_extractor(features_cfg)
    train_index = np.asarray(train_index)
    if train_index.size == 0 or train_index.min() < 0 or train_index.max() >= len(dataset):
        raise BearingTwinError(f"train_index must hold indices into the {len(dataset)} windows of {dataset.key or 'the dataset'}")
    if isinstance(extractor, RawFeatures):
        return extractor.fit(dataset.windows[train_index]).transform(dataset.windows), [], extractor
    if isinstance(extractor, EnvelopeOrderFeatures):  # milliseconds per window: not worth a cache file
        rpms = dataset.window_rpms
        extractor.fit(dataset.windows[train_index], fs_hz=dataset.fs, rpm=None if rpms is None else rpms[train_index])
        return extractor.transform(dataset.windows, fs_hz=dataset.fs, rpm=rpms), [], extractor
    path = cache_path(features_cfg, dataset, train_index, cache_dir)
    stored = load_npz_or_heal(path, "features", "table")
    if stored is not None:
        log.info("features: cache hit %s", path)
        features, table = stored["features"], json.loads(str(stored["table"]))
        # The stored table is the fitted state (per_sample fits nothing: its rows are per window).
        extractor.vmd_params_ = [] if extractor.vmd_params == "per_sample" else table
        return features, table, extractor
    log.info("features: extracting %d windows into %s", len(dataset), path)
    extractor.fit(dataset.windows[train_index], dataset.labels[train_index])
    features, table = extractor.extract(dataset.windows, dataset.labels)
    save_npz_atomic(path, features=features, table=np.array(json.dumps(table)))
    return features, table, extractor
