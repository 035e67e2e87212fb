"""Diagnosing recordings with trained models: the fitted pipeline, its MLflow model, physics evidence."""
