"""bearingtwin's Hydra launcher (Hydra finds launchers only in the ``hydra_plugins`` package)."""
