"""One entry to every data source: ``build_dataset(cfg)`` dispatches on ``cfg.data.source``.

Bearing reconciliation: the ``bearing`` config group describes the bearing the *twin*
simulates. A measured dataset's bearing is a fact of the measurement, so real-data
configs name it (``data.bearing``, logged as the param ``data.bearing``); the ``bearing``
group is not used to build real data (it only feeds the simulator). An experiment that
simulates and measures together selects the matching group itself (``bearing=cwru_6205``).
"""

from __future__ import annotations

from omegaconf import DictConfig

from bearingtwin.data.recording import WindowedDataset
from bearingtwin.errors import BearingTwinError


def _simulated(cfg: DictConfig) -> WindowedDataset:
    from bearingtwin.data.simulated import build_simulated_dataset

    return build_simulated_dataset(cfg.data, cfg.bearing, cfg.simulator, cfg.effects, cfg.paths.cache_dir)


def _cwru(cfg: DictConfig) -> WindowedDataset:
    from bearingtwin.data.real import build_cwru_dataset

    return build_cwru_dataset(cfg.data)  # its folder is data.root (${paths.data_root}/cwru by default)


def _hust(cfg: DictConfig) -> WindowedDataset:
    from bearingtwin.data.real import build_hust_dataset

    return build_hust_dataset(cfg.data)


SOURCES = {"simulated": _simulated, "cwru": _cwru, "hust": _hust}


def build_dataset(cfg: DictConfig) -> WindowedDataset:
    """The windowed dataset the composed config describes (``data``, plus ``bearing``,
    ``simulator``, ``effects`` and ``paths`` as the source needs them)."""
    source = cfg.data.get("source")
    if source not in SOURCES:
        raise BearingTwinError(f"data.source={source!r} is not a data source; choose one of {', '.join(SOURCES)}")
    return SOURCES[source](cfg)

