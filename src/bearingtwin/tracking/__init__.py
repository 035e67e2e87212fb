"""MLflow logging of runs and the reports that read them back."""


def open_command(tracking_uri: str) -> str:
    """How to look at the runs of a store: a server is opened in a browser, a local store with ``mlflow ui``."""
    if tracking_uri.startswith(("http://", "https://")):
        return f"open {tracking_uri}"
    relative = tracking_uri.removeprefix("sqlite:///") if tracking_uri.startswith("sqlite:///") else None
    if relative and not relative.startswith("/") and relative != ":memory:":  # read from where this process runs:
        from pathlib import Path  # said absolute, it opens from anywhere (a run's folder under hydra.job.chdir=true)

        tracking_uri = f"sqlite:///{Path(relative).resolve()}"
    return f"mlflow ui --backend-store-uri {tracking_uri}"
