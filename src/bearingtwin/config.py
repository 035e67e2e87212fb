"""Where the Hydra configs live, and the error handling every entry point shares."""

from __future__ import annotations

import functools
import sys
from pathlib import Path
from typing import Callable

from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

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

    return wrapped


def plain_config(cfg, name: str = "config") -> dict:
    """A config node (or mapping) as a plain, resolved dict; a missing value (``???``) is an
    error naming ``name``, so a half-filled config never reaches a computation or a cache key."""
    if isinstance(cfg, DictConfig):
        try:
            return OmegaConf.to_container(cfg, resolve=True, throw_on_missing=True)
        except OmegaConfBaseException as error:  # its message runs over several lines; keep the first, name the key
            raise BearingTwinError(f"{getattr(error, 'full_key', None) or name}: {str(error).splitlines()[0]}") from None
    return dict(cfg or {})


def bearing_config(name: str) -> dict:
    """``conf/bearing/<name>.yaml`` composed as Hydra would (its defaults chain applied), as a dict.

    Works inside a running Hydra app (which has initialized Hydra) and outside one.
    """
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from hydra.errors import MissingConfigException

    try:
        if GlobalHydra.instance().is_initialized():
            cfg = compose(overrides=[f"+bearing={name}"])
        else:
            with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
                cfg = compose(overrides=[f"+bearing={name}"])
    except MissingConfigException:
        raise BearingTwinError(f"bearing {name!r}: no such bearing config in {CONF_DIR}/bearing") from None
    return OmegaConf.to_container(cfg.bearing, resolve=True)
