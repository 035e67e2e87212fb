"""MLflow logging of runs and the reports that read them back."""
