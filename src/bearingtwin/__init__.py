"""bearingtwin: a digital twin of a motor bearing, and fault diagnosis trained on it.

Importing the package pins the CPU kernels torch and Intel MKL choose, before either is loaded: both pick
their kernels by the machine's instruction set (AVX2, AVX-512; an Intel or an AMD processor), and the
network's training on one machine's kernels and another's ends a window apart (the main job: 95.00 %
with torch's AVX2 kernels, 96.11 % with its AVX-512 ones, on one machine). Pinned to torch's portable kernels
(``ATEN_CPU_CAPABILITY=default``) and MKL's conditional numerical reproducibility (``MKL_CBWR=COMPATIBLE``),
with oneDNN's just-in-time kernels held to SSE4.1, every x86-64 machine runs the network's arithmetic alike
(numpy's own vector code still differs in the twelfth digit of the features). The paper's network costs no
time by it, the raw-window network 1.3x to fit (benchmarks/cpu_kernels.py). A value already set in the
environment is kept.

Numba's compiled kernels are cached with the user's other caches (``NUMBA_CACHE_DIR``, by default
``$XDG_CACHE_HOME/bearingtwin/numba`` or ``~/.cache/bearingtwin/numba``), not in ``__pycache__`` beside the sources,
which may be a checkout that no command writes into or an installation the user cannot write to.
"""

import os
import platform
import sys
import warnings

PINNED_CPU_KERNELS = {"ATEN_CPU_CAPABILITY": "default", "MKL_CBWR": "COMPATIBLE", "DNNL_MAX_CPU_ISA": "SSE41"}
PINS_CPU_KERNELS = platform.machine().lower() in ("x86_64", "amd64")
"""Whether this machine's kernels are pinned: the variables name x86 instruction sets."""


def cpu_kernels() -> str:
    """The kernel settings this process runs with (``ATEN_CPU_CAPABILITY=default, ...``), as a run records them: a
    value the environment set before bearingtwin did is what was used, and torch's own answer where it is loaded
    (imported before bearingtwin, it may have chosen its kernels before the pin)."""
    settings = {name: os.environ.get(name, "the machine") for name in PINNED_CPU_KERNELS}
    if "torch" in sys.modules:
        settings["ATEN_CPU_CAPABILITY"] = _torch_kernels()
    return ", ".join(f"{name}={value}" for name, value in settings.items())


def _torch_kernels() -> str:
    """The instruction set torch's kernels use (``default``, ``avx2``, ``avx512``); torch must be loaded."""
    return sys.modules["torch"].backends.cpu.get_cpu_capability().lower()


def _pin_cpu_kernels() -> None:
    if not PINS_CPU_KERNELS:
        return
    for name, value in PINNED_CPU_KERNELS.items():
        os.environ.setdefault(name, value)
    # torch reads the pin when it first runs an operation: a script that ran one before importing bearingtwin has
    # the machine's kernels for good, and its network may end a window apart from the same seed's elsewhere.
    if "torch" in sys.modules and _torch_kernels() != os.environ["ATEN_CPU_CAPABILITY"]:
        warnings.warn(f"torch chose its {_torch_kernels()} kernels before bearingtwin could pin them: a network "
                      "trained in this process may differ from the same seed's on another machine; import "
                      "bearingtwin before torch", stacklevel=3)


_pin_cpu_kernels()


def _numba_cache_dir() -> str:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "bearingtwin", "numba")


if not os.environ.get("NUMBA_CACHE_DIR"):  # read once, when numba is first imported; empty reads as unset
    os.environ["NUMBA_CACHE_DIR"] = _numba_cache_dir()
