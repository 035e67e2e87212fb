"""Test-session isolation: no test writes into the checkout's caches or MLflow store.

Caches and the default MLflow store are redirected to a per-session temporary
folder through the same environment variables a user would set, so the code paths
under test are the real ones.

One OpenMP / BLAS thread per process (torch's network, numpy's linear algebra), in this process
and in every command a test starts: two workers on two cores, each often with two children,
already fill the machine, and threads spinning for a busy core slow an LSTM's many small steps
several times over (the README's smoke raw CNN-BiLSTM run: 64 s beside the other commands, 18 s
on one thread). Numbers do not depend on it beyond the float32 rounding of the network's losses;
``OMP_NUM_THREADS`` set by the caller is kept.
"""

import os
import tempfile

_session_dir = tempfile.mkdtemp(prefix="bearingtwin-tests-")
os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ["BEARINGTWIN_CACHE"] = os.path.join(_session_dir, "cache")
os.environ["MLFLOW_TRACKING_URI"] = "sqlite:///" + os.path.join(_session_dir, "mlflow.db")
