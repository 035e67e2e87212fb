"""The code MLflow loads for a bearingtwin model ("models from code": no pickled object).

``mlflow.pyfunc.load_model(uri)`` runs this file; the pipeline itself comes from the model's
``pipeline`` artifact (:mod:`bearingtwin.diagnosis.mlflow_model`).
"""

from mlflow.models import set_model

from bearingtwin.diagnosis.mlflow_model import DiagnosisModel

set_model(DiagnosisModel())
