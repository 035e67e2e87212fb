"""Test-session isolation: no test writes into the checkout's caches or MLflow store.

Caches and the default MLflow store are redirected to a per-session temporary
folder through the same environment variables a user would set, so the code paths
under test are the real ones.
"""

import os
import tempfile

_session_dir = tempfile.mkdtemp(prefix="bearingtwin-tests-")
os.environ.setdefault("MPLBACKEND", "Agg")
os.environ["BEARINGTWIN_CACHE"] = os.path.join(_session_dir, "cache")
os.environ["MLFLOW_TRACKING_URI"] = "sqlite:///" + os.path.join(_session_dir, "mlflow.db")
