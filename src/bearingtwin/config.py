"""Where the Hydra configs live, and the error handling every entry point shares."""

from __future__ import annotations

import difflib
import errno
import functools
import os
import re
import shutil
import sys
import tempfile
import warnings
from pathlib import Path
from typing import Callable, Mapping, NoReturn
from urllib.parse import urlparse

import hydra
import yaml
from hydra.errors import ConfigCompositionException, MissingConfigException, OverrideParseException
from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import (ConfigAttributeError, ConfigKeyError, InterpolationResolutionError, MissingMandatoryValue,
                              OmegaConfBaseException)

from bearingtwin.errors import BearingTwinError

REPO_ROOT = Path(__file__).resolve().parents[2]
CONF_DIR = str(REPO_ROOT / "conf")

# ``${bt_repo:}`` in a config resolves to the checkout, so default paths work from any cwd.
OmegaConf.register_new_resolver("bt_repo", lambda: str(REPO_ROOT), replace=True)
# ``${bt_normpath:<path>}``: ``<path>`` with its ``..`` taken out, as a command prints it (/work/shared/data, not
# /work/main/../shared/data).
OmegaConf.register_new_resolver("bt_normpath", os.path.normpath, replace=True)


def _home() -> str:
    """The user's home: HOME, else the password database's (``os.path.expanduser``); for a user with neither, a folder
    of the user's own in the temporary folder. Never one every user shares (/tmp/.cache), nor a relative ``~``."""
    home = os.path.expanduser("~")
    return home if os.path.isabs(home) else os.path.join(tempfile.gettempdir(), f"bearingtwin-{os.getuid()}")


OmegaConf.register_new_resolver("bt_home", _home, replace=True)


def _environment(name: str, *default) -> str | None:
    """``${bt_env:NAME,default}``: the environment variable, or ``default`` where it is unset or empty, as MLflow reads
    its variables and the XDG base directory specification its paths (``oc.env`` keeps an empty value:
    ``BEARINGTWIN_CACHE=`` had put the cache in the current folder, ``XDG_CACHE_HOME=`` at /bearingtwin). A default is
    text, as ``oc.env``'s; ``null`` stays None."""
    value = os.environ.get(name)
    if value:
        return value
    if not default:
        raise ValueError(f"environment variable {name!r} is not set, and ${{bt_env:{name}}} gives no default")
    return None if default[0] is None else str(default[0])


OmegaConf.register_new_resolver("bt_env", _environment, replace=True)


def data_root() -> Path:
    """The folder of real measurements as the configs read it (``paths.data_root``: BEARINGTWIN_DATA, else
    ../shared/data beside the checkout), for scripts and tests that read records without a command's config."""
    return Path(OmegaConf.create({"paths": OmegaConf.load(Path(CONF_DIR) / "paths" / "default.yaml")}).paths.data_root)


COMPOSITION_ERRORS = (ConfigCompositionException, OverrideParseException)
"""What Hydra raises for overrides it cannot compose into a config (MissingConfigException is one)."""


def exit_on_user_error(task: Callable) -> Callable:
    """Turn a :class:`BearingTwinError`, or a config Hydra cannot compose from the user's overrides,
    into a one-line message on stderr and exit status 2.

    Wraps the body of a single-run entry point (apply it *inside* ``@hydra.main`` so
    Hydra has composed the config), or a step that composes configs itself (a sweep's jobs).
    Programming errors keep their tracebacks.
    """

    @functools.wraps(task)
    def wrapped(*args, **kwargs):
        try:
            return task(*args, **kwargs)
        except BearingTwinError as error:
            _refuse(str(error))
        except MissingMandatoryValue as error:  # a ``???`` the user did not fill in
            key = getattr(error, "full_key", "") or "a mandatory value"
            _refuse(f"{key} is missing; give {key}=<value>")
        except COMPOSITION_ERRORS as error:
            _refuse(composition_error_line(error))
        except ConfigAttributeError as error:
            key = str(getattr(error, "full_key", "") or "")
            removed = [arg for arg in sys.argv[1:] if arg.startswith("~") and key
                       and (key + ".").startswith(arg[1:].partition("=")[0] + ".")]
            if not removed:  # no setting of the user's took this key away: a programming error, with its traceback
                raise
            _refuse(f"{key} is needed, and {removed[0]} removed it")
        except InterpolationResolutionError as error:  # seed=${foo}: a value naming a key no config has
            where = next((arg for arg in sys.argv[1:] if "${" in arg), None) or getattr(error, "full_key", "") or "a setting"
            _refuse(f"{where}: {str(error).splitlines()[0]} (an interpolation ${{...}} names another setting)")
        except OSError as error:
            # A full disk or a file-size limit where no step of ours wrote: a library's own cache (numba's compiled
            # kernels) is one line too, naming the file; any other OSError is a traceback, as a fault of ours is.
            if error.errno not in (errno.ENOSPC, errno.EFBIG, errno.EDQUOT):
                raise
            what = f"{error.filename}: cannot be written" if error.filename else "a file could not be written"
            _refuse(f"{what} ({error.strerror}): free some space, or raise the file-size limit, and run it again")

    return wrapped


def _refuse(message: str) -> NoReturn:
    """A user's mistake said in one line on stderr, exit status 2, leaving no empty run folder behind."""
    print(f"error: {message}", file=sys.stderr)
    _drop_empty_run_folder()
    sys.exit(2)


def _drop_empty_run_folder() -> None:
    """Hydra's own folder of a single run refused before it did anything removed: ``outputs/<date>/<time>/`` (its
    default ``hydra.run.dir``, not one the user named, which may have existed before), holding the run's config
    and an empty log only, and the date folder and ``outputs/`` where that leaves them empty. A mistyped value then
    leaves no folder behind."""
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    if not HydraConfig.initialized() or HydraConfig.get().mode != RunMode.RUN:
        return
    hydra_cfg = HydraConfig.get()
    if any(override.startswith(("hydra.run.dir=", "hydra.run=")) for override in hydra_cfg.overrides.hydra):
        return
    folder, here = Path(hydra_cfg.runtime.output_dir).resolve(), Path.cwd().resolve()
    if folder.parent.parent != here / "outputs" or not folder.is_dir():
        return
    if any(not (entry.name == ".hydra" or (entry.suffix == ".log" and entry.is_file() and entry.stat().st_size == 0))
           for entry in folder.iterdir()):
        return
    shutil.rmtree(folder, ignore_errors=True)
    for parent in (folder.parent, folder.parent.parent):  # outputs/<date>/, then outputs/, where left empty
        if not parent.is_dir() or any(parent.iterdir()):
            break
        parent.rmdir()


def output_folder(path, key: str = "out") -> Path:
    """``path`` as a folder to write into, refused in one line when it or a folder above it is a file:
    checked before any work, so a typo in ``out=`` costs nothing. An empty value is refused too: it would be the
    current folder, which the user did not name."""
    if not str(path).strip():
        raise BearingTwinError(f"{key} must name a folder, got {str(path)!r}")
    path = Path(str(path)).expanduser()
    for part in (path, *path.parents):
        if part.exists():
            if not part.is_dir():
                raise BearingTwinError(f"{key}={path}: {part} is a file, not a folder")
            try:  # the nearest folder that exists must take new files (a read-only or pseudo file system does not)
                with tempfile.TemporaryFile(dir=part):
                    pass
            except OSError as error:
                raise BearingTwinError(f"{key}={path}: nothing can be written in {part} ({error.strerror})") from None
            break
    return path


_command_config: list[str] = []
"""The config of the command running in this process (:func:`hydra_command` sets it): a sweep's jobs are composed
before Hydra's own config of the run, which names it, is set."""


def _closest_in_running_config(key: str) -> str:
    """"did you mean <key>?" (:func:`closest_setting`) against the running command's config as its defaults compose it,
    for a key a sweep's job could not compose (``-m classifer=svm,knn``); "" outside a command or where none is close."""
    if not _command_config:
        return ""
    try:
        return closest_setting(compose_config(_command_config[-1]), key)
    except Exception:  # the defaults do not compose either: the plain line says enough
        return ""


def composition_error_line(error: ConfigCompositionException | OverrideParseException) -> str:
    """Hydra's message for a config it could not compose, on one line naming the group or key at fault.

    Hydra's own message runs over several lines (the options, then its whole config search path)
    and its command exits 1, like a crash; the common mistakes get a line of their own.
    """
    cause = error.__cause__ if isinstance(error.__cause__, OmegaConfBaseException) else None
    if isinstance(error, MissingConfigException) and "/" in (error.missing_cfg_file or ""):
        group, option = error.missing_cfg_file.rsplit("/", 1)
        # Hydra lists the options for a group's one choice, not for an item of a list (effects=[gear]).
        options = error.options or sorted(path.stem for path in Path(CONF_DIR, group).glob("*.yaml"))
        if options:
            own = own_config_hint(option) if group == "bearing" else ""
            return f"{group}={option}: no such {group} config; choose one of {', '.join(options)}{own}"
    if isinstance(cause, (ConfigAttributeError, ConfigKeyError)) and getattr(cause, "full_key", None):
        key = str(cause.full_key)
        if key.startswith("hydra.launcher."):  # each launcher has settings of its own; Hydra's basic one none to speak of
            having = options_declaring(key)
            where = (f"; {' and '.join(f'launcher={name}' for name in having)} {'has' if len(having) == 1 else 'have'} it"
                     if having else "; check its spelling (--cfg hydra lists the launcher's settings)")
            return f"{key}: not a setting of this launcher{where}"
        listing = "--cfg hydra" if key.startswith("hydra.") else "--cfg job"
        closest = "" if key.startswith("hydra.") else _closest_in_running_config(key)
        return options_hint(key) or (f"{key}: not a setting (no config declares it); "
                                     + (closest or f"check its spelling ({listing} lists the settings)"))
    if isinstance(error, OverrideParseException):
        key, equals, value = error.override.partition("=")
        # Hydra reads a bare value in a grammar of its own: spaces, brackets (a glob's [123]), a caret (m/s^2) and
        # letters outside ASCII (a file name in another script) need quotes, which its message does not say.
        quoted = (f"; give the value in quotes: '{key}=\"{value}\"'"
                  if equals and value and not set(value) & set("'\"") and value[0] not in "[{" else "")
        return f"{error.override}: not an override Hydra can read ({str(error).splitlines()[0]}){quoted}"
    repeated = re.match(r"Multiple values for (\S+)\. To override a value use 'override \S+: (\S+)'", str(error))
    if repeated:  # Hydra's advice is for a defaults list; on the command line the group is chosen without +
        group, option = repeated.groups()
        return (f"+{group}={option}: {group} has a default choice, which + would add to; choose it with "
                f"{group}={option}")
    lines = []
    for line in str(error).splitlines():
        if line.startswith("Config search path:"):  # the rest is the path, one folder a line
            break
        if line.strip():
            lines.append(line.strip().rstrip("."))
    if cause is not None:
        lines.append(str(cause).splitlines()[0])
    return "; ".join(lines) or type(error).__name__


def _group_of(key: str) -> str | None:
    """The config group a setting belongs to (``classifier.learning_rate``: ``classifier``; a launcher's settings,
    ``hydra.launcher.n_jobs``: ``launcher``), the longest dotted prefix that is a folder of ``conf/``."""
    if key.startswith("hydra.launcher."):
        return "launcher"
    parts = key.split(".")
    groups = [".".join(parts[:i]) for i in range(len(parts) - 1, 0, -1) if Path(CONF_DIR, *parts[:i]).is_dir()]
    return groups[0] if groups else None


@functools.cache  # the files of conf/ only: a refusal's check and its message ask once per process
def options_declaring(key: str, config_name: str = "train") -> tuple[str, ...]:
    """The options of the config group ``key`` belongs to whose config declares it (``hydra.launcher.n_jobs``:
    joblib; ``features.vmd_params``: the features that tune VMD)."""
    group = _group_of(key)
    if group is None:
        return ()
    parent, _, leaf = key.rpartition(".")
    having = []
    for option in sorted(path.stem for path in Path(CONF_DIR, *group.split(".")).glob("*.yaml")):
        try:
            cfg = compose_config(config_name, [f"{group}={option}"], hydra_node=group == "launcher")
        except Exception:  # an option this command does not compose (a launcher whose plugin is not installed)
            continue
        node = OmegaConf.select(cfg, parent, default=None)
        if isinstance(node, DictConfig) and leaf in node:
            having.append(option)
    return tuple(having)


def options_hint(key: str, config_name: str = "train") -> str:
    """The line for a setting some options of its group declare and the one composed does not (a sweep over
    ``classifier=svm,cnn_bilstm`` with ``classifier.learning_rate``: only the network has one); "" where no
    option declares it."""
    having = options_declaring(key, config_name)
    if not having:
        return ""
    group = _group_of(key)
    names = " and ".join(f"{group}={name}" for name in having)
    one = len(having) == 1
    return (f"{key}: only {names} {'has' if one else 'have'} it, not the {group} chosen (--cfg job shows its settings); "
            f"give it with {'that' if one else 'one of those'}, or sweep {'it' if one else 'those'} apart from the rest")


def prints_only(argv: list[str]) -> bool:
    """Whether ``argv`` asks Hydra to print and run nothing (``--help``, ``--hydra-help``, ``--cfg``, ``--info``, in
    any spelling its parser reads: ``--cfg=job``, ``-cjob``)."""
    from hydra._internal.utils import get_args_parser  # Hydra's own parser: the same reading of argv

    args, _ = get_args_parser().parse_known_args(argv)
    return bool(args.help or args.hydra_help or args.cfg or args.info)


def _end_quietly() -> None:
    """End the command when the reader of its output left (``| head``): exit 1, no traceback."""
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # Python's advice (the signal docs)
    sys.exit(1)


class _EndsWhenReaderLeaves:
    """``sys.stdout`` whose closed pipe ends the command (SystemExit, which Hydra's and logging's handlers of
    Exception let through) rather than raising BrokenPipeError into code that catches it and prints a traceback."""

    def __init__(self, stream):
        self._stream = stream

    def write(self, text: str) -> int:
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            _end_quietly()

    def flush(self) -> None:
        try:
            self._stream.flush()
        except BrokenPipeError:
            _end_quietly()

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


def hydra_command(config_name: str) -> Callable:
    """``@hydra.main`` on ``conf/<config_name>.yaml``, with the overrides checked first.

    Hydra reports an override it cannot compose (an unknown config group option, a key no config
    declares, an unreadable value) over several lines and exits 1, from inside ``hydra.main``
    where an entry point cannot catch it. So the command line is composed here first, as Hydra
    is about to compose it, and such a mistake ends the command with one line and exit status 2;
    so does a single run's ``+key`` no config declares (:func:`refuse_unknown_keys`), before Hydra
    starts the run's callbacks (MLflow's) and the task imports its libraries.
    Everything else (``--help``, ``--cfg``, ``-m``, the task's own errors) is Hydra's as before.
    """

    def decorate(task: Callable) -> Callable:
        @functools.wraps(task)
        def task_reading_inputs_from_launch_folder(cfg: DictConfig):
            inputs_from_launch_folder(cfg)
            return task(cfg)

        hydra_main = hydra.main(version_base="1.3", config_path=CONF_DIR,
                                config_name=config_name)(task_reading_inputs_from_launch_folder)

        @functools.wraps(task)
        def command(cfg_passthrough: DictConfig | None = None):
            _command_config.append(config_name)
            if cfg_passthrough is None:  # run as a command: the overrides are on the command line
                exit_on_user_error(refuse_bad_overrides)(config_name, sys.argv[1:])
            if not sys.stderr.isatty():  # MLflow's download bars, like the project's own, only in a terminal
                os.environ.setdefault("MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR", "false")
            # stdout holds the closing block alone, which names the run and how to open it; a tracking server's runs
            # had added MLflow's "View run <name> at <url>" lines to it as they ended.
            os.environ.setdefault("MLFLOW_SUPPRESS_PRINTING_URL_TO_STDOUT", "true")
            if prints_only(sys.argv[1:]):
                # Hydra catches a closed pipe's error where it prints these (in a logging handler, or around --cfg)
                # and prints a traceback: the error ends the command where it is raised.
                sys.stdout = _EndsWhenReaderLeaves(sys.stdout)
            try:
                result = hydra_main(cfg_passthrough)
                sys.stdout.flush()  # here, not at exit, where a closed pipe's error is printed past any handler
                return result
            except BrokenPipeError:  # the reader left (``--help | head``): nothing more to say, and no traceback
                _end_quietly()

        return command

    return decorate


INPUT_PATH_KEYS = ("path", "labels", "reference", "measured.path", "paths.data_root", "paths.cache_dir", "data.root",
                   "data.labels", "data.calibration.report", "data.calibration.healthy.report", "tracking.artifact_root",
                   "tracking.uri")
"""Settings that name a file or folder the user gives (records and labels read, a cache, a store, an artifact folder):
taken from the folder the command was started in, also where ``hydra.job.chdir=true`` starts the task in its run's
folder. An ``out=`` is what the run writes, and stays in the run's folder there."""


def inputs_from_launch_folder(cfg: DictConfig) -> None:
    """Under ``hydra.job.chdir=true``, :func:`absolute_inputs` from the folder the command was started in, as Hydra's
    :func:`hydra.utils.to_absolute_path` reads a path; without it, nothing changes (the task starts in that folder)."""
    from hydra.core.hydra_config import HydraConfig

    if HydraConfig.initialized() and HydraConfig.get().job.get("chdir"):
        absolute_inputs(cfg, str(HydraConfig.get().runtime.cwd))


def absolute_inputs(cfg: DictConfig, launch_folder: str) -> None:
    """Each of ``cfg``'s :data:`INPUT_PATH_KEYS` given as a relative path (the file of a ``sqlite:///`` store too)
    made absolute from ``launch_folder``; URIs of other kinds (``http:``, ``databricks``, ``mlflow-artifacts:``,
    ``file:``), home-relative paths (expanded where they are read) and absolute ones are left as given. A sweep's
    jobs and the sweep that waits for them read the same values by it (their config hashes)."""
    from omegaconf import open_dict

    for key in INPUT_PATH_KEYS:
        try:
            value = OmegaConf.select(cfg, key, default=None, throw_on_missing=False)
        except InterpolationResolutionError:  # it names a value not given: the task says so, as it would without this
            continue
        if not isinstance(value, str) or not value:
            continue
        if value.startswith("sqlite:///"):  # the store's file: SQLAlchemy reads it from the working folder, ~ included
            scheme, path = "sqlite:///", value[len("sqlite:///"):]
        elif len(urlparse(value).scheme) > 1 or key == "tracking.uri" or value.startswith("~"):
            continue  # a URI (one letter is a drive, not a scheme), a store of another kind, or a home-relative path
        else:
            scheme, path = "", value
        if path and path != ":memory:" and not Path(path).is_absolute():
            with open_dict(cfg):
                OmegaConf.update(cfg, key, scheme + str(Path(launch_folder) / path))


def _groups_taking_lists(config_name: str) -> set[str]:
    """The config groups ``config_name``'s defaults list takes a list of options from (``- effects: []``)."""
    path = Path(CONF_DIR, f"{config_name}.yaml")
    defaults = OmegaConf.load(path).get("defaults", []) if path.is_file() else []
    return {group for entry in defaults if OmegaConf.is_dict(entry)
            for group, value in entry.items() if OmegaConf.is_list(value)}


RECORDED_SOURCES = ("cwru", "hust", "files")
"""Data sources that read recordings: the twin's ``simulator`` and ``effects`` make none of their windows."""


def unread_overrides(cfg: DictConfig, overrides: list[str]) -> list[str]:
    """What the command line sets that the composed run never reads, each with why: the twin's settings where the data
    are recordings, the Lightning trainer's where the classifier is no network. Said, not refused: a set of small
    sizes (``trainer.max_epochs=2 ...``) is given to any classifier. Where the run's data or classifier is swept, its
    jobs differ in what they read, and nothing is said of it."""
    from hydra.core.override_parser.overrides_parser import OverridesParser

    parsed = OverridesParser.create().parse_overrides(overrides)
    swept = {o.key_or_group for o in parsed if o.is_sweep_override()}
    swept |= {key.lstrip("+~") for key in ((cfg.get("hydra") or {}).get("sweeper") or {}).get("params") or {}}
    source = (cfg.get("data") or {}).get("source")
    classifier = (cfg.get("classifier") or {}).get("name")
    unread = []
    for override in parsed:
        group = override.key_or_group.split(".")[0]
        if group in ("simulator", "effects") and source in RECORDED_SOURCES and not {"data", "experiment"} & swept:
            unread.append(f"{override.input_line} not read: data={source} reads recordings, which the twin's simulator "
                          "and effects do not make (they make data=simulated and data=twin_to_real)")
        elif group == "trainer" and classifier not in (None, "cnn_bilstm") and not {"classifier", "method"} & swept:
            unread.append(f"{override.input_line} not read: the trainer is the CNN-BiLSTM's, and classifier={classifier} "
                          "trains without it")
    return unread


def _top_level_keys(config_name: str) -> set[str]:
    """The keys ``conf/<config_name>.yaml`` itself sets (none for a config of the user's own, ``--config-name``)."""
    path = Path(CONF_DIR, f"{config_name}.yaml")
    return set(OmegaConf.load(path)) if path.is_file() else set()


def refuse_bad_overrides(config_name: str, argv: list[str]) -> None:
    """Compose the config ``argv`` asks for, in the mode Hydra will run it, raising Hydra's composition error
    (and, for a single run, the :class:`BearingTwinError` of a ``+key`` no config declares).

    Left to Hydra: its help and information flags, which compose nothing or report their own
    way, and another config folder (``--config-path``, ``--config-dir``), which this check would
    not see. An error that is not about composition is left for Hydra to report when it composes.
    """
    from hydra import initialize_config_dir
    from hydra._internal.utils import get_args_parser  # Hydra's own parser: the same reading of argv
    from hydra.core.global_hydra import GlobalHydra
    from hydra.types import RunMode

    args, flags = get_args_parser().parse_known_args(argv)
    if flags:  # argparse's refusal: its whole usage and a line at the end, as if the command had failed to start
        key, _, value = flags[0].lstrip("-").partition("=")
        raise BearingTwinError(f"{flags[0]}: not a flag of this command; settings are given as key=value: "
                               f"{key}={value or '<value>'} (--help lists them)")
    if args.multirun and args.cfg:  # Hydra's own refusal is a ValueError with a traceback
        raise BearingTwinError(f"-m and --cfg {args.cfg} go one at a time: --cfg shows one run's config; leave out -m "
                               "to see it (--cfg hydra shows the sweep's parameters under hydra.sweeper.params)")
    modes = [flag for flag, given in (("-m", args.multirun), ("--cfg", args.cfg), ("--info", args.info),
                                      ("--shell-completion", args.shell_completion)) if given]
    if len(modes) > 1:  # as above: Hydra's refusal of the pair is a traceback
        raise BearingTwinError(f"{' and '.join(modes)} go one at a time: give one of them")
    other = args.config_name
    if other and other != config_name and not args.config_dir and not args.config_path and (
            Path(CONF_DIR) / f"{other}.yaml").is_file():  # Hydra ran it, and the task failed on a key it lacks
        raise BearingTwinError(f"-cn {other}: conf/{other}.yaml is bearingtwin-{other}'s config, without this command's "
                               f"settings; this command composes conf/{config_name}.yaml (a copy of it of your own: "
                               "-cd <folder> -cn <name>)")
    if args.config_dir and not Path(args.config_dir).is_dir():  # Hydra's refusal: three lines, exit 1 (no ~ read)
        raise BearingTwinError(f"--config-dir {args.config_dir}: no such folder (it holds configs of one's own, "
                               "beside the project's)")
    if args.help or args.hydra_help or args.info or args.shell_completion or args.experimental_rerun \
            or args.config_path or args.config_dir:
        return
    name = args.config_name or config_name
    for override in args.overrides:
        key, equals, value = override.partition("=")
        if not equals and not override.startswith(("+", "~")) and "path" in _top_level_keys(name) \
                and (Path(override).expanduser().exists() or set(override) & set("/.*")):
            raise BearingTwinError(f"{override}: a file, folder or glob is given as path='{override}'")
        group = key.lstrip("+~")
        if Path(CONF_DIR, group).is_dir() and value.startswith("{"):  # Hydra would merge it as an option's name
            options = ", ".join(sorted(path.stem for path in Path(CONF_DIR, group).glob("*.yaml")))
            if group in _groups_taking_lists(name):  # effects=[noise,...]: each option's settings under its own name
                raise BearingTwinError(f"{override}: {group} takes a list of its options' names ({options}); give "
                                       f"their settings apart: {group}=[<option>,...] {group}.<option>.<key>=<value>")
            raise BearingTwinError(f"{override}: a config group takes the name of one of its options ({options}); "
                                   f"give its settings apart: {group}=<option> {group}.<key>=<value>")
        if Path(CONF_DIR, group).is_dir() and (value.startswith(("/", "~", ".")) or value.endswith((".yaml", ".yml"))):
            raise BearingTwinError(f"{override}: a config group takes the name of a config, not a file: put the file in "
                                   f"<folder>/{group}/<name>.yaml and give {group}=<name> with "
                                   "hydra.searchpath=[file://<folder>]")
    refuse_absent_search_path(args.overrides)
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"), warnings.catch_warnings():
        warnings.filterwarnings("ignore", "provider=hydra.searchpath")  # an absent folder: named below, in one line
        app = GlobalHydra.instance().hydra
        try:
            # As Hydra's _run_hydra: -m, or else the config's hydra.mode; --cfg shows a run's config.
            mode = RunMode.MULTIRUN if args.multirun else (None if args.cfg else app.get_mode(name, args.overrides))
            cfg = app.compose_config(name, list(args.overrides), run_mode=mode or RunMode.RUN)
        except COMPOSITION_ERRORS as error:
            key = getattr(error.__cause__, "full_key", None)
            if isinstance(error.__cause__, (ConfigAttributeError, ConfigKeyError)) and key and not key.startswith("hydra."):
                rest = [o for o in args.overrides if o.partition("=")[0].lstrip("+~") != key]
                try:
                    hint = closest_setting(app.compose_config(name, rest, run_mode=mode or RunMode.RUN), key)
                except Exception:  # the rest does not compose either: Hydra's own message names the first fault
                    hint = ""
                hint = (f"{key}: not a setting (no config declares it); {hint}" if hint else
                        options_hint(key, name))  # composes every option of the group: asked once
                if hint:
                    raise BearingTwinError(hint) from None
            raise
        except yaml.YAMLError as error:  # a config file of the user's own that is no YAML: Hydra prints a traceback
            raise BearingTwinError(yaml_error_line(error)) from None
        except ValueError as error:  # Hydra's own check of a group override, raised as a plain ValueError
            # null, or a value Hydra reads as a number or a truth value (bearing=6205, an SKF bearing by its number)
            groups = [(key.lstrip("+~"), value) for key, _, value in (o.partition("=") for o in args.overrides)
                      if Path(CONF_DIR, key.lstrip("+~")).is_dir() and value
                      and isinstance(yaml.safe_load(value), (type(None), bool, int, float))]
            if not groups:
                return
            group, value = groups[0]
            options = sorted(path.stem for path in Path(CONF_DIR, group).glob("*.yaml"))
            if value == "null":
                raise BearingTwinError(f"{group}=null: a config group takes one of its options ({', '.join(options)}); "
                                       "leave it out for its default") from error
            holding = [option for option in options if value in option]
            hint = f": {' or '.join(f'{group}={option}' for option in holding)}?" if holding else ""
            raise BearingTwinError(f"{group}={value}: a config group takes the name of one of its options "
                                   f"({', '.join(options)}){hint}") from error
        except Exception:  # not a composition error: Hydra meets it again when it composes, and reports it
            return
        if cfg.get("data", {}).get("source") == "simulated":  # the data set's operating point is the simulator's
            from bearingtwin.data.simulated import DATA_SET_OPERATING_POINT

            for override in args.overrides:
                group, _, name = override.lstrip("+~").partition("=")[0].partition(".")
                if group == "simulator" and name in DATA_SET_OPERATING_POINT:
                    raise BearingTwinError(f"{override}: the simulated data set runs the simulator at data.{name} "
                                           f"({cfg.data[name]}); give data.{name}=<value>")
        if mode == RunMode.MULTIRUN and str(cfg.hydra.sweeper.get("_target_", "")).endswith(".BasicSweeper"):
            from hydra.core.override_parser.overrides_parser import OverridesParser

            for override in OverridesParser.create().parse_overrides(list(args.overrides)):
                if override.is_interval_sweep():  # Hydra's refusal: a traceback's last line, exit 1, once the sweep starts
                    raise BearingTwinError(f"{override.input_line}: interval() asks a sweeper that draws values (Optuna's, "
                                           "Nevergrad's); Hydra's basic sweeper takes lists (a,b), range() and choice()")
        if not args.cfg and cfg.hydra.get("output_subdir") is not None:  # Hydra writes its .hydra folder there
            key = "hydra.sweep.dir" if mode == RunMode.MULTIRUN else "hydra.run.dir"
            try:
                folder = OmegaConf.select(cfg, key)
            except Exception:  # it reads what Hydra sets as the run starts (${hydra:runtime.choices.classifier})
                folder = None
            if folder is not None:
                output_folder(folder, key)  # Hydra's own refusal: a traceback, exit 1
        if isinstance(cfg.get("bearing"), DictConfig):  # a file of the user's own: a misspelt key would pass unseen
            check_bearing_keys(cfg.bearing, cfg.hydra.runtime.choices.get("bearing") or cfg.bearing.get("name"))
            if cfg.hydra.runtime.choices.get("bearing"):  # chosen by its file's name, not only +bearing.<key>=
                check_sizes_stated(cfg.hydra.runtime.choices.bearing, [str(f) for f in cfg.hydra.searchpath],
                                   [o for o in args.overrides if o.lstrip("+~").startswith("bearing.")])
        tracking = cfg.get("tracking") or {}
        if "experiment" in tracking and tracking.get("enabled") is not False:  # no store is used with tracking off
            experiment_name(cfg.tracking)
        if mode != RunMode.MULTIRUN:  # a sweep's jobs are checked by SweepParentRun, each with its own values
            given = {o.partition("=")[0].lstrip("+~") for o in args.overrides}
            swept = {key.lstrip("+~"): values for key, values in (cfg.hydra.sweeper.get("params") or {}).items()
                     if key.lstrip("+~") not in given}
            if swept and not args.cfg:  # one run of a sweep's settings: its swept parameters would pass without a word
                print(f"warning: one run, not a sweep: {', '.join(swept)} take their defaults, not the sweep's values "
                      f"({'; '.join(f'{key}: {values}' for key, values in swept.items())}); add -m to sweep them",
                      file=sys.stderr)
            refuse_unknown_keys(cfg.hydra)
        # Last: a command refused above says one line, not a warning beside it.
        for warning in [] if args.cfg else unread_overrides(cfg, list(args.overrides)):  # --cfg shows, runs nothing
            print(f"warning: {warning}", file=sys.stderr)


def experiment_name(tracking_cfg, key: str = "tracking.experiment") -> str:
    """``tracking_cfg.experiment``, refused in one line naming ``key`` where it is empty (an unset shell variable's
    value), which MLflow would refuse with a traceback."""
    name = "" if tracking_cfg.get("experiment") is None else str(tracking_cfg.experiment)
    if not name.strip():
        raise BearingTwinError(f"{key} is empty: name an MLflow experiment, or leave the setting out for the "
                               "command's own")
    return name


def compose_config(config_name: str | None = None, overrides=(), hydra_node: bool = False) -> DictConfig:
    """A config composed from ``conf/`` as Hydra would, inside a running Hydra app or outside one; ``hydra_node``:
    with Hydra's own settings (``hydra.launcher``, ...)."""
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    if GlobalHydra.instance().is_initialized():
        return compose(config_name, overrides=list(overrides), return_hydra_config=hydra_node)
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(config_name, overrides=list(overrides), return_hydra_config=hydra_node)


def bearing_config(name: str, key: str = "bearing", own_hint: bool = True) -> dict:
    """``conf/bearing/<name>.yaml`` composed as Hydra would (its defaults chain applied), as a dict named ``name``;
    a name that is not one of those files raises naming ``key``, the setting it came from, before
    Hydra parses it (a name may come from a served model's request: ``own_hint`` false leaves out how a command
    finds a bearing of one's own, which a request cannot do)."""
    search_path = search_path_override()
    choices = bearing_choices(search_path)
    if name not in choices:
        raise BearingTwinError(f"{key}={name}: no such bearing config; choose one of {', '.join(choices)}"
                               f"{own_config_hint(name) if own_hint else ''}")
    config = OmegaConf.to_container(compose_config(overrides=[f"+bearing={name}", *search_path]).bearing, resolve=True)
    check_bearing_keys(config, name)
    check_sizes_stated(name)
    return {**config, "name": name}  # a file that names none inherits its defaults' name; a bearing is its file


def refuse_absent_search_path(overrides: list[str]) -> None:
    """Refuse a ``hydra.searchpath`` folder that is not there, naming it (Hydra warns over two lines, then fails to
    find the config that folder was to hold, naming the config, not the folder)."""
    from hydra.core.override_parser.overrides_parser import OverridesParser

    given = [o for o in overrides if o.partition("=")[0].lstrip("+") == "hydra.searchpath"]
    try:
        folders = OverridesParser.create().parse_overrides(given[-1:])[0].value() if given else []
    except OverrideParseException:  # Hydra names it, in one line, where it composes
        return
    for folder in folders if isinstance(folders, list) else [folders]:
        scheme, _, where = str(folder).rpartition("://")
        if scheme in ("", "file") and not Path(where).is_dir():
            slashes = " (an absolute path is file:///<path>, three slashes)" if not where.startswith("/") else ""
            raise BearingTwinError(f"hydra.searchpath: {folder} is not a folder{slashes}")
        group = Path(where).name
        if (scheme in ("", "file") and Path(CONF_DIR, group).is_dir() and not Path(where, group).is_dir()
                and any(Path(where).glob("*.yaml"))):  # conf/bearing given where conf is meant: Hydra finds nothing
            raise BearingTwinError(f"hydra.searchpath: {folder} is a {group} folder itself; give the folder that holds "
                                   f"it, {scheme + '://' if scheme else ''}{Path(where).parent}")


def yaml_error_line(error: yaml.YAMLError) -> str:
    """A YAML parser's error as one line naming the file and line (its message runs over several)."""
    mark = getattr(error, "problem_mark", None)
    where = f"{mark.name}, line {mark.line + 1}" if mark is not None else "a config file"
    return f"{where}: not valid YAML ({getattr(error, 'problem', None) or str(error).splitlines()[0]})"


BEARING_SCHEMA = "paper"
"""The bearing config whose settings every bearing config holds (Table 1's, with the geometry)."""


@functools.cache
def bearing_settings() -> tuple[str, ...]:
    """The settings of ``conf/bearing/paper.yaml`` (:data:`BEARING_SCHEMA`), read once per process."""
    return tuple(OmegaConf.load(Path(CONF_DIR, "bearing", f"{BEARING_SCHEMA}.yaml")))


def check_bearing_keys(bearing, name: str | None) -> None:
    """Refuse a bearing config (``bearing=<name>``, a file of the user's own) whose settings are not those of
    ``conf/bearing/paper.yaml``: a misspelt key would leave the value its defaults give in place, unnoticed; a file
    without ``defaults: [paper]`` lacks the masses and stiffnesses the twin needs."""
    settings = bearing_settings()
    where = f"bearing={name}" if name else "bearing"  # keys added with +bearing.<key>= and no bearing chosen
    unknown = [key for key in bearing if key not in settings]
    if unknown:
        raise BearingTwinError(f"{where}: {unknown[0]} is not a bearing setting (its value would be left unused); "
                               f"the settings are {', '.join(settings)}")
    missing = [key for key in settings if key not in bearing]
    if missing:
        raise BearingTwinError(f"{where}: {missing[0]} is missing; start the file with 'defaults: [paper]', as "
                               "conf/bearing/cwru_6205.yaml does, to keep Table 1's values for the settings it does not give")


def bearing_file(name: str, search_path: list[str] | None = None) -> Path | None:
    """The YAML file ``bearing=<name>`` names: the project's ``conf/bearing/<name>.yaml``, else the first folder of
    ``search_path`` (the running command's ``hydra.searchpath`` where not given) that holds ``bearing/<name>.yaml``;
    None where no folder does (a package's)."""
    from hydra.core.hydra_config import HydraConfig

    if search_path is None:
        search_path = list(HydraConfig.get().searchpath) if HydraConfig.initialized() else []
    for folder in [str(CONF_DIR), *search_path]:
        if not folder.startswith("pkg://"):
            path = Path(folder.removeprefix("file://")) / "bearing" / f"{name}.yaml"
            if path.is_file():
                return path
    return None


def check_sizes_stated(name: str, search_path: list[str] | None = None, overrides: list[str] | None = None) -> None:
    """Refuse a bearing file that leaves a size (:data:`~bearingtwin.physics.geometry.SIZE_KEYS`) to Table 1's
    ``paper.yaml``: ``defaults: [paper]`` would put that bearing's 9 balls in its place, and every defect frequency with
    them. A size counts as given in the file, in a bearing file of its defaults other than ``paper``
    (``defaults: [cwru_6205]``), or on the command line (``overrides``, the running command's where not given)."""
    from bearingtwin.physics.geometry import SIZE_KEYS

    path = bearing_file(name, search_path)
    if path is None or name == BEARING_SCHEMA:
        return
    overrides = bearing_overrides() if overrides is None else overrides
    on_command_line = {override.lstrip("+~").partition("=")[0].removeprefix("bearing.") for override in overrides}
    missing = [key for key in SIZE_KEYS if key not in _sizes_stated(path, search_path) | on_command_line]
    if missing:
        raise BearingTwinError(f"{path}: gives no {', '.join(missing)}; a bearing's file states its sizes "
                               f"({', '.join(SIZE_KEYS)}) or takes them from another bearing's file: left to "
                               "'defaults: [paper]', they would be Table 1's bearing's")


def _sizes_stated(path: Path, search_path: list[str] | None, seen: tuple[Path, ...] = ()) -> set[str]:
    """The sizes the bearing file ``path`` states, itself or through the bearing files of its defaults but Table 1's
    (one not found on disk, a package's, is taken to state them all: nothing says otherwise)."""
    from bearingtwin.physics.geometry import SIZE_KEYS

    content = OmegaConf.load(path)  # as written: its defaults not applied
    stated = {key for key in SIZE_KEYS if key in content}
    for entry in content.get("defaults") or []:
        other_name = str(entry).removeprefix("/bearing/") if isinstance(entry, str) else BEARING_SCHEMA
        if other_name in ("_self_", BEARING_SCHEMA):
            continue
        other = bearing_file(other_name, search_path)
        stated |= (set(SIZE_KEYS) if other is None or other in seen
                   else _sizes_stated(other, search_path, (*seen, path)))
    return stated


def own_config_hint(name: str) -> str:
    """How a bearing of the user's own is found, for a message naming a bearing config that does not exist."""
    return f", or describe yours in <folder>/bearing/{name}.yaml and add hydra.searchpath=[file://<folder>]"


def search_path_override(folders: list[str] | None = None) -> list[str]:
    """The running Hydra command's ``hydra.searchpath`` (the folders a user added, a bearing of their own among
    them), or ``folders``, as an override for a config composed inside the command; none outside a command (a served
    model)."""
    from hydra.core.hydra_config import HydraConfig

    if folders is None:
        folders = list(HydraConfig.get().searchpath) if HydraConfig.initialized() else []
    if all(re.fullmatch(r"[A-Za-z0-9_:/.-]+", folder) for folder in folders):  # as a user writes it: [file:///home/me/conf]
        return [f"hydra.searchpath=[{','.join(folders)}]"] if folders else []
    quoted = ",".join("'" + folder.replace("\\", "\\\\").replace("'", "\\'") + "'" for folder in folders)
    return [f"hydra.searchpath=[{quoted}]"] if folders else []


def bearing_overrides() -> list[str]:
    """The running command's overrides of the bearing's own settings (``bearing.n_balls=12``), as given; none
    outside a command."""
    from hydra.core.hydra_config import HydraConfig

    if not HydraConfig.initialized():
        return []
    return [override for override in HydraConfig.get().overrides.task if override.lstrip("+~").startswith("bearing.")]


def given_on_command_line(key: str) -> bool | None:
    """Whether the running Hydra command's overrides (``hydra.overrides.task``: a sweep job's own included) name
    ``key``, as a config group or a value (``bearing=cwru_6203``, ``+bearing=...``, ``~bearing``), or a key under
    it (``bearing.n_balls=8``); None outside a Hydra run (a config composed by a test or a script), where nothing
    tells a value given from a default."""
    from hydra.core.hydra_config import HydraConfig
    from hydra.core.override_parser.overrides_parser import OverridesParser

    if not HydraConfig.initialized():
        return None
    overrides = OverridesParser.create().parse_overrides(list(HydraConfig.get().overrides.task))
    return any(o.key_or_group == key or o.key_or_group.startswith(f"{key}.") for o in overrides)


def bearing_choices(overrides: list[str] = ()) -> list[str]:
    """The ``bearing`` configs a name may choose: the project's and, inside a Hydra command, those its search
    path adds (``overrides``: :func:`search_path_override`), as Hydra itself finds them."""
    from hydra.core.global_hydra import GlobalHydra

    if GlobalHydra.instance().is_initialized():
        return sorted(GlobalHydra.instance().config_loader().get_group_options("bearing", overrides=list(overrides)))
    return sorted(path.stem for path in Path(CONF_DIR, "bearing").glob("*.yaml"))


def unknown_bearing_note(named: str, consequence: str, key: str = "bearing") -> str | None:
    """A note when ``named``, the bearing a file names, is no bearing config this command finds (its search path
    included), saying ``consequence`` and the setting ``key`` that names one; None when it is one."""
    if str(named) in bearing_choices(search_path_override()):
        return None
    return (f"the file names bearing {named}, which no conf/bearing config here describes: {consequence} (give "
            f"{key}=<name>, with hydra.searchpath for one of your own)")


def refuse_unknown_bearing(named: str, source: str, key: str = "bearing") -> None:
    """Refuse a record (``source``: its file, or the data's setting) whose file names a bearing no config this command
    finds, where no ``key`` says which to read: another bearing's defect lines stood in for its own, read without a
    word beyond a log line (a twin fitted a defect of 0.002 mm for one of 0.28 mm)."""
    note = unknown_bearing_note(named, "its defect frequencies are unknown here", key)
    if note is not None:
        raise BearingTwinError(f"{source}: {note}")


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
        except MissingMandatoryValue as error:  # said as exit_on_user_error says a command's own ???
            key = getattr(error, "full_key", None) or name
            raise BearingTwinError(f"{key} is missing; give {key}=<value>") from None
        except OmegaConfBaseException as error:  # its message runs over several lines; keep the first, name the key
            raise BearingTwinError(f"{getattr(error, 'full_key', None) or name}: {str(error).splitlines()[0]}") from None
    if cfg is not None and not isinstance(cfg, Mapping):  # a bearing's name or its BearingGeometry, from Python
        raise BearingTwinError(f"{name}: give a mapping of settings (a composed config's node, or for a bearing "
                               f"bearing_config('<name>')), got {type(cfg).__name__} {str(cfg)[:60]!r}")
    return dict(cfg or {})


def flatten(container: dict, prefix: str = "") -> dict[str, str]:
    """``{"a": {"b": 1}}`` -> ``{"a.b": "1"}``; lists become their string form."""
    flat = {}
    for key, value in container.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict) and value:
            flat.update(flatten(value, f"{name}."))
        else:
            flat[name] = str(value)
    return flat


MULTI_OPTION_GROUPS = {"effects"}
"""Config groups that take a list of options (``effects=[noise,tones]``); every other takes one."""


NAMED_OTHERWISE = {"windows_per_record": "samples_per_class", "samples_per_class": "windows_per_record"}
"""Settings one data source names one way and the others another (``data=files``: windows per record)."""


def closest_setting(cfg: DictConfig, key: str) -> str:
    """"did you mean <key>?" naming the setting beside ``key`` in ``cfg`` closest to it (a misspelling, two letters
    swapped, or the name another data source gives it), or "" where none is close."""
    parent, _, leaf = key.rpartition(".")
    node = OmegaConf.select(cfg, parent, default=None) if parent else cfg
    if not isinstance(node, DictConfig):
        return ""
    names = [str(name) for name in node]
    match = ([NAMED_OTHERWISE[leaf]] if NAMED_OTHERWISE.get(leaf) in names
             else difflib.get_close_matches(leaf, names, n=1, cutoff=0.75)
             or [name for name in names if sorted(name) == sorted(leaf)])  # letters swapped: rmp, a short rpm
    if match == [leaf]:
        match = []
    return f"did you mean {parent + '.' if parent else ''}{match[0]}?" if match else ""


def _free_form(cfgs: list[DictConfig], key: str) -> bool:
    """Whether some map on ``key``'s path, in any of ``cfgs``, takes keys no config declares: a class's arguments
    beside its ``_target_``, or a map a config group declares empty (``{}``)."""
    parts = key.split(".")
    maps = [cfg if i == 0 else OmegaConf.select(cfg, ".".join(parts[:i]), default=None)
            for i in range(len(parts)) for cfg in cfgs]
    return any(isinstance(node, DictConfig) and (len(node) == 0 or "_target_" in node) for node in maps)


def _refuse_undeclared_keys_of_file(config_name: str, chosen_as: str, without: DictConfig, with_file: DictConfig) -> None:
    """Refuse a config file chosen with ``+group=option`` (``chosen_as``: an experiment's, a sweep's) that sets a key
    no config declares (``seeed: 3`` in an experiment would be carried along unread, the run taking the default):
    ``with_file`` composed with it, ``without`` with the same groups' choices and not it."""
    declared = OmegaConf.to_container(without, resolve=False)  # a mandatory ??? is declared, as its text
    for key in flatten(OmegaConf.to_container(with_file, resolve=False)):
        node, parts = declared, key.split(".")
        for part in parts:  # as far as the configs declare the key's path; a map declared null the file fills in
            if not isinstance(node, dict) or part not in node:
                break
            node = node[part]
        else:
            continue
        if node is not None and not _free_form([without, with_file], key):
            hint = closest_setting(without, key)
            raise BearingTwinError(f"{chosen_as}: {key} is not a setting of {config_name} (no config declares it)"
                                   + (f"; {hint}" if hint else ""))


def refuse_unknown_keys(hydra_cfg) -> None:
    """Raise naming a ``+key=value`` override that adds a key no config declares.

    Hydra lets ``+`` add any key, so ``+simulator.foo=1`` would be carried along unused. A
    key may be added only into a free-form map: a class's arguments beside its ``_target_``
    (``+classifier.estimator.n_estimators=300``: the class checks them), or a map a config group declares
    empty (``{}``, e.g. ``data.fs_by_record``, ``data.twin.variants``), also when an experiment has filled it in
    (``+experiment=sim2real`` spans ``data.twin.variants.spin_slip``; ``+data.twin.variants.preload...``
    adds beside it); ``+group=option`` selects a config group and is always allowed. ``hydra_cfg``
    is a run's (or a sweep job's) ``hydra`` node; the config is composed again without the added
    keys to see what the configs declare, and with the groups' choices alone (no experiment, no
    value) to see which maps they declare empty.
    """
    from hydra.core.override_parser.overrides_parser import OverridesParser

    config_name = hydra_cfg.job.config_name
    overrides = OverridesParser.create().parse_overrides(list(hydra_cfg.overrides.task))
    groups = set(hydra_cfg.runtime.choices)
    for override in overrides:  # Hydra merges a list of a group's options into one config, half of each
        is_group = override.key_or_group in groups or (Path(CONF_DIR) / override.key_or_group).is_dir()
        if is_group and override.key_or_group not in MULTI_OPTION_GROUPS and isinstance(override.value(), list):
            group = override.key_or_group
            raise BearingTwinError(f"{group}={override.get_value_element_as_str()}: choose one {group} (a list merges "
                                   f"their settings into one config); to run each, sweep them: -m {group}=a,b")
    added = [o for o in overrides if (o.is_add() or o.is_force_add()) and o.key_or_group not in groups]
    added_groups = {o.key_or_group for o in overrides if (o.is_add() or o.is_force_add()) and o.key_or_group in groups}
    if not added and not added_groups:
        return
    # The user's own config folders, where an experiment or a group's option of their own is found.
    searched = search_path_override(list(hydra_cfg.searchpath or []))
    chosen = [*searched, *(f"{group}={choice}" for group, choice in hydra_cfg.runtime.choices.items()
                           if not group.startswith("hydra") and group not in added_groups and isinstance(choice, str))]
    groups_alone = compose_config(config_name, chosen)
    for group in sorted(added_groups):  # an experiment's or a sweep's file may set only what some config declares
        choice = hydra_cfg.runtime.choices.get(group)
        if isinstance(choice, str):
            _refuse_undeclared_keys_of_file(config_name, f"+{group}={choice}", groups_alone,
                                            compose_config(config_name, [*chosen, f"+{group}={choice}"]))
    if not added:
        return
    declared = compose_config(config_name, [*searched, *(o.input_line for o in overrides if o not in added)])
    for override in added:
        key = override.key_or_group
        if OmegaConf.select(declared, key, default=None) is not None:
            continue  # ``++key=`` on a declared key
        # Free-form: some map on the key's path is empty as composed, or as the groups alone declare it.
        if not _free_form([declared, groups_alone], key):
            hint = closest_setting(declared, key)
            raise BearingTwinError(
                f"{override.input_line}: {key} is not a setting of {config_name} (no config declares it); "
                + (hint or "check its spelling, or set a declared key without '+'")
            )
