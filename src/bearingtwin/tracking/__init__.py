"""MLflow logging of runs and the reports that read them back."""


def open_command(tracking_uri: str) -> str:
    """How to look at the runs of a store: a server is opened in a browser, a local store with ``mlflow ui``."""
    if tracking_uri.startswith(("http://", "https://")):
        return f"open {tracking_uri}"
    return f"mlflow ui --backend-store-uri {tracking_uri}"
