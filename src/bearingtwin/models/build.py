"""Build a classifier from its config group (``classifier=cnn_bilstm`` | ``classifier=svm``)."""

from __future__ import annotations

from omegaconf import DictConfig, OmegaConf

from bearingtwin.checks import show_progress_bar
from bearingtwin.errors import BearingTwinError
from bearingtwin.models.svm import SvmClassifier

# The network's module (torch, Lightning: seconds to import) is imported only when a network is built.
CLASSIFIERS = ("cnn_bilstm", "svm")


def build_classifier(classifier_cfg: DictConfig, trainer_cfg: DictConfig, seed: int, root_dir: str | None = None):
    """An unfitted scikit-learn-style classifier; every key but ``name`` is a constructor argument.

    ``trainer_cfg`` (epochs, gradient clipping, accelerator) applies to the network only;
    ``seed`` is the run's seed; ``root_dir`` is where Lightning may write (the Hydra run dir).
    """
    show_progress_bar(trainer_cfg.get("progress_bar", False), in_sweep=True)  # a bad value fails here, in a sweep's job
    params = OmegaConf.to_container(classifier_cfg, resolve=True)
    name = params.pop("name", None)
    if name not in CLASSIFIERS:
        raise BearingTwinError(f"classifier.name={name!r} is not a classifier; choose one of {', '.join(CLASSIFIERS)}")
    if name == "cnn_bilstm":
        from bearingtwin.models.cnn_bilstm import CnnBiLstmClassifier

        trainer = OmegaConf.to_container(trainer_cfg, resolve=True)
        network = CnnBiLstmClassifier(**params, **trainer, random_state=seed, root_dir=root_dir)
        network.check_params()  # bad settings fail before any data is built
        return network
    svm = SvmClassifier(**params, random_state=seed)
    svm.check_params()  # bad settings fail before any data is built
    return svm
