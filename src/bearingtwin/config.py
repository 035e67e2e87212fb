"""Where the Hydra configs live, and the error handling every entry point shares."""

from __future__ import annotations

import functools
import sys
from pathlib import Path
from typing import Callable

from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import MissingMandatoryValue, OmegaConfBaseException

from bearingtwin.errors import BearingTwinError

REPO_ROOT = Path(__file__).resolve().parents[2]
CONF_DIR = str(REPO_ROOT / "conf")

# ``${bt_repo:}`` in a config resolves to the checkout, so default paths work from any cwd.
OmegaConf.register_new_resolver("bt_repo", lambda: str(REPO_ROOT), replace=True)


def exit_on_user_error(task: Callable) -> Callable:
    """Turn a :class:`BearingTwinError` into a one-line message on stderr and exit status 2.

    Wraps the body of a single-run entry point (apply it *inside* ``@hydra.main`` so
    Hydra has composed the config). Programming errors keep their tracebacks.
    """

    @functools.wraps(task)
    def wrapped(*args, **kwargs):
        try:
            return task(*args, **kwargs)
        except BearingTwinError as error:
            print(f"error: {error}", file=sys.stderr)
            sys.exit(2)
        except MissingMandatoryValue as error:  # a ``???`` the user did not fill in
            key = getattr(error, "full_key", "") or "a mandatory value"
            print(f"error: {key} is missing; give {key}=<value>", file=sys.stderr)
            sys.exit(2)

    return wrapped


def compose_config(config_name: str | None = None, overrides=()) -> DictConfig:
    """A config composed from ``conf/`` as Hydra would, inside a running Hydra app or outside one."""
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    if GlobalHydra.instance().is_initialized():
        return compose(config_name, overrides=list(overrides))
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(config_name, overrides=list(overrides))


def bearing_config(name: str, key: str = "bearing") -> dict:
    """``conf/bearing/<name>.yaml`` composed as Hydra would (its defaults chain applied), as a dict;
    an unknown name raises naming ``key``, the setting it came from."""
    from hydra.errors import MissingConfigException

    try:
        cfg = compose_config(overrides=[f"+bearing={name}"])
    except MissingConfigException:
        raise BearingTwinError(f"{key}={name!r}: no such bearing config in {CONF_DIR}/bearing") from None
    return OmegaConf.to_container(cfg.bearing, resolve=True)


def load_bearing(name: str, key: str = "bearing"):
    """The :class:`~bearingtwin.physics.geometry.BearingGeometry` of ``conf/bearing/<name>.yaml``."""
    from bearingtwin.physics.geometry import BearingGeometry

    return BearingGeometry.from_config(bearing_config(name, key))


def plain_config(cfg, name: str = "config") -> dict:
    """A config node (or mapping) as a plain, resolved dict; a missing value (``???``) is an
    error naming ``name``, so a half-filled config never reaches a computation or a cache key."""
    if isinstance(cfg, DictConfig):
        try:
            return OmegaConf.to_container(cfg, resolve=True, throw_on_missing=True)
        except OmegaConfBaseException as error:  # its message runs over several lines; keep the first, name the key
            raise BearingTwinError(f"{getattr(error, 'full_key', None) or name}: {str(error).splitlines()[0]}") from None
    return dict(cfg or {})


def refuse_unknown_keys(hydra_cfg) -> None:
    """Raise naming a ``+key=value`` override that adds a key no config declares.

    Hydra lets ``+`` add any key, so ``+simulator.foo=1`` would be carried along unused. A
    key may be added only into a free-form map, one the configs declare empty (``{}``, e.g.
    ``data.fs_by_record``, ``data.twin.variants``); ``+group=option`` selects a config group
    and is always allowed. ``hydra_cfg`` is a run's (or a sweep job's) ``hydra`` node; the
    config is composed again without the added keys to see what the configs declare.
    """
    from hydra.core.override_parser.overrides_parser import OverridesParser

    config_name = hydra_cfg.job.config_name
    overrides = OverridesParser.create().parse_overrides(list(hydra_cfg.overrides.task))
    groups = set(hydra_cfg.runtime.choices)
    added = [o for o in overrides if (o.is_add() or o.is_force_add()) and o.key_or_group not in groups]
    if not added:
        return
    declared = compose_config(config_name, [o.input_line for o in overrides if o not in added])
    for override in added:
        key = override.key_or_group
        if OmegaConf.select(declared, key, default=None) is not None:
            continue  # ``++key=`` on a declared key
        node, parts = declared, key.split(".")
        for part in parts[:-1]:
            if not isinstance(node, DictConfig) or part not in node:
                break
            node = node[part]
        if not (isinstance(node, DictConfig) and len(node) == 0):
            raise BearingTwinError(
                f"{override.input_line}: {key} is not a setting of {config_name} (no config declares it); "
                "check its spelling, or set a declared key without '+'"
            )
