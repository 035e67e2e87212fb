"""The paper's CNN-BiLSTM (section 3.3) as a Lightning module, with a scikit-learn face.

Architecture, as the paper gives it: Conv1d (1 -> 8 filters, kernel 6), ReLU,
BatchNorm1d, MaxPool1d(2), a bidirectional LSTM of 30 hidden units, Dropout 0.2,
a fully connected layer to 4 classes and softmax (here: CrossEntropyLoss on the
logits, which is softmax + log-loss in one numerically stable step). Training: Adam,
learning rate 0.01, L2 factor 0.001, gradient threshold 1.0, 100 epochs.

Where MATLAB's ``trainNetwork`` (the paper's tool) and PyTorch differ, we choose:

- **L2 factor.** MATLAB adds ``L2/2 * ||w||^2`` to the loss, i.e. ``L2 * w`` to the
  gradient *before* the Adam moments; PyTorch's ``Adam(weight_decay=L2)`` adds exactly
  ``L2 * w`` to the gradient before the moments (coupled L2, not AdamW's decoupled
  decay), so the factor carries over unchanged. MATLAB's ``BiasL2Factor`` defaults to 0,
  so the biases of the convolution, LSTM and fully connected layers are not decayed;
  batch-norm scale and offset are (MATLAB's ``Scale/OffsetL2Factor`` default to 1).
- **Gradient threshold.** MATLAB's default ``l2norm`` method clips each parameter
  tensor's gradient separately; Lightning's ``gradient_clip_val`` clips the global norm
  of all gradients, which is at least as strict. We use Lightning's.
- **Mini-batch.** MATLAB's default ``MiniBatchSize`` is 128 (the paper names none);
  ``batch_size`` defaults to 128 and the training set is reshuffled every epoch.
- **BiLSTM output.** MATLAB's sequence-to-label networks use ``OutputMode="last"``:
  the BiLSTM output at the last time step (forward and backward halves) feeds the
  fully connected layer. ``lstm_output="last"`` does that; ``"flatten"`` feeds all
  time steps instead.
- **Input.** Each sample is a one-channel sequence: the nine features (batch, 1, 9)
  or a raw window (batch, 1, 2048). Columns are standardized with statistics of the
  training set only (for raw windows the per-position statistics are all close to the
  signal's overall ones, so this equals scaling by the training signal's level).
"""

from __future__ import annotations

import contextlib
import logging
import sys
import tempfile
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path

import lightning as L
import numpy as np
import torch
from lightning.pytorch.accelerators import AcceleratorRegistry
from lightning.pytorch.callbacks import TQDMProgressBar
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.preprocessing import StandardScaler
from sklearn.utils.validation import column_or_1d
from torch import nn
from torch.utils.data import DataLoader, TensorDataset

from bearingtwin.checks import finite_number, whole_number
from bearingtwin.errors import BearingTwinError
from bearingtwin.models.classes import prediction_data, training_classes, training_data

LSTM_OUTPUTS = ("last", "flatten")


@dataclass(frozen=True)
class CnnBiLstmShape:
    """Layer sizes of the network; validated so a bad config names its field, whole numbers made ints (a
    sweep's ``30.0`` is 30 hidden units: torch's layers take ints only)."""

    input_length: int
    n_classes: int = 4
    n_filters: int = 8
    kernel_size: int = 6
    pool_size: int = 2
    hidden_units: int = 30
    dropout: float = 0.2
    lstm_output: str = "last"

    def __post_init__(self) -> None:
        settings = {"input_length": whole_number("the network's input length", self.input_length),
                    "n_classes": whole_number("the number of classes", self.n_classes),
                    **check_layer_settings(self.n_filters, self.kernel_size, self.pool_size, self.hidden_units,
                                           self.dropout, self.lstm_output)}
        for name, value in settings.items():
            object.__setattr__(self, name, value)  # frozen: the checked value replaces the given one once
        if self.sequence_length < 1:
            raise BearingTwinError(
                f"an input of {self.input_length} points is too short for classifier.kernel_size="
                f"{self.kernel_size} followed by classifier.pool_size={self.pool_size}"
            )

    @property
    def sequence_length(self) -> int:
        """Time steps the BiLSTM sees: after a 'valid' convolution and non-overlapping pooling."""
        return (self.input_length - self.kernel_size + 1) // self.pool_size


def check_layer_settings(n_filters, kernel_size, pool_size, hidden_units, dropout, lstm_output) -> dict:
    """The ``classifier.*`` layer settings by name, whole numbers as ints; raise naming the first with an
    impossible value (a text, a zero)."""
    settings = {name: whole_number(f"classifier.{name}", value)
                for name, value in (("n_filters", n_filters), ("kernel_size", kernel_size), ("pool_size", pool_size),
                                    ("hidden_units", hidden_units))}
    settings["dropout"] = finite_number("classifier.dropout", dropout, "a number in [0, 1)")
    if not 0.0 <= settings["dropout"] < 1.0:
        raise BearingTwinError(f"classifier.dropout must lie in [0, 1), got {dropout}")
    if lstm_output not in LSTM_OUTPUTS:
        raise BearingTwinError(f"classifier.lstm_output={lstm_output!r}; choose one of {', '.join(LSTM_OUTPUTS)}")
    return {**settings, "lstm_output": lstm_output}


class CnnBiLstmModule(L.LightningModule):
    """CNN-BiLSTM network, its loss, optimizer and per-epoch training curves.

    ``history`` collects one dict per epoch (``epoch``, ``train_loss``, ``train_accuracy``
    and, when a validation set is given, ``val_loss``, ``val_accuracy``) so curves can be
    logged after fitting without a Lightning logger writing files.
    """

    def __init__(self, shape: CnnBiLstmShape, learning_rate: float = 0.01, l2_factor: float = 0.001) -> None:
        super().__init__()
        self.shape = shape
        self.learning_rate = learning_rate
        self.l2_factor = l2_factor
        self.features = nn.Sequential(
            nn.Conv1d(1, shape.n_filters, shape.kernel_size),
            nn.ReLU(),
            nn.BatchNorm1d(shape.n_filters),
            nn.MaxPool1d(shape.pool_size),
        )
        self.bilstm = nn.LSTM(shape.n_filters, shape.hidden_units, batch_first=True, bidirectional=True)
        self.dropout = nn.Dropout(shape.dropout)
        steps_to_fc = 1 if shape.lstm_output == "last" else shape.sequence_length
        self.classify = nn.Linear(2 * shape.hidden_units * steps_to_fc, shape.n_classes)
        self.loss = nn.CrossEntropyLoss()
        self.history: list[dict] = []
        self._epoch_sums: dict[str, list[float]] = {}

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Logits (batch, n_classes) of inputs (batch, 1, input_length)."""
        sequence, _ = self.bilstm(self.features(x).transpose(1, 2))
        if self.shape.lstm_output == "last":
            sequence = sequence[:, -1, :]
        return self.classify(self.dropout(sequence.flatten(1)))

    def _accumulate(self, stage: str, batch) -> torch.Tensor:
        x, y = batch
        logits = self(x)
        loss = self.loss(logits, y)
        sums = self._epoch_sums.setdefault(stage, [0.0, 0.0, 0.0])
        sums[0] += float(loss.detach()) * len(y)
        sums[1] += float((logits.argmax(1) == y).sum())
        sums[2] += len(y)
        return loss

    def training_step(self, batch, batch_idx):
        loss = self._accumulate("train", batch)
        if self.trainer.progress_bar_callback is not None:  # the batch's loss on the epoch bar; no logger writes it
            self.log("loss", loss.detach(), prog_bar=True, on_step=True, on_epoch=False)
        return loss

    def validation_step(self, batch, batch_idx):
        self._accumulate("val", batch)

    def on_train_epoch_end(self) -> None:
        # Lightning runs validation before this hook, so both stages are summed by now.
        record = {"epoch": self.current_epoch}
        for stage, (loss_sum, correct, count) in self._epoch_sums.items():
            record[f"{stage}_loss"] = loss_sum / count
            record[f"{stage}_accuracy"] = correct / count
        self.history.append(record)
        self._epoch_sums = {}

    def configure_optimizers(self):
        unregularized = {id(m.bias) for m in self.modules() if isinstance(m, (nn.Conv1d, nn.Linear))}
        unregularized |= {id(p) for name, p in self.bilstm.named_parameters() if name.startswith("bias")}
        decayed = [p for p in self.parameters() if id(p) not in unregularized]
        plain = [p for p in self.parameters() if id(p) in unregularized]
        return torch.optim.Adam(
            [{"params": decayed, "weight_decay": self.l2_factor}, {"params": plain, "weight_decay": 0.0}],
            lr=self.learning_rate,
        )


class SequenceDataModule(L.LightningDataModule):
    """Standardized samples as (n, 1, length) float32 tensors; the training set reshuffled each epoch."""

    def __init__(self, X_train, y_train, X_val=None, y_val=None, batch_size: int = 128, seed: int = 0) -> None:
        super().__init__()
        self.train = _tensor_dataset(X_train, y_train)
        self.val = None if X_val is None else _tensor_dataset(X_val, y_val)
        self.batch_size = batch_size
        self.seed = seed

    def train_dataloader(self):
        generator = torch.Generator().manual_seed(self.seed)
        return DataLoader(self.train, batch_size=self.batch_size, shuffle=True, generator=generator)

    def val_dataloader(self):
        return [] if self.val is None else DataLoader(self.val, batch_size=self.batch_size)


def _tensor_dataset(X: np.ndarray, y: np.ndarray) -> TensorDataset:
    return TensorDataset(torch.as_tensor(X, dtype=torch.float32).unsqueeze(1), torch.as_tensor(y, dtype=torch.long))


def check_accelerator(name) -> None:
    """Raise naming ``trainer.accelerator`` unless Lightning knows it and this machine has it ("auto" and "gpu" are
    Lightning's own aliases), so a run asking for a GPU that is not there fails before any data is built."""
    known = sorted(AcceleratorRegistry.available_accelerators())
    if name == "auto":
        return
    if not isinstance(name, str) or name not in (*known, "gpu"):
        raise BearingTwinError(f"trainer.accelerator={name!r} is not an accelerator Lightning knows; "
                               f"choose auto or one of {', '.join(['gpu', *known])}")
    present = [key for key in known if AcceleratorRegistry[key]["accelerator"].is_available()]
    wanted = ("cuda", "mps") if name == "gpu" else (name,)
    if not any(key in present for key in wanted):
        raise BearingTwinError(f"trainer.accelerator={name}: this machine has no such device (it has: "
                               f"{', '.join(present)}); use trainer.accelerator=auto or cpu")


class CnnBiLstmClassifier(ClassifierMixin, BaseEstimator):
    """scikit-learn wrapper: ``CnnBiLstmClassifier(**params).fit(X, y).predict(X)``.

    ``X`` is (n_samples, sequence_length): nine features or a raw window per row.
    ``eval_set=(X_val, y_val)`` in :meth:`fit` only records validation curves; it never
    steers training (no early stopping), so passing the test set does not leak it.
    ``progress_bar=True`` shows Lightning's epoch bar on stderr; anything else (``trainer.progress_bar``'s
    ``auto`` before the entry point resolves it) keeps training silent.

    Fitted attributes: ``classes_``, ``n_features_in_``, ``scaler_``, ``module_``, ``history_`` (per-epoch
    loss and accuracy), ``device_`` (where it trained: ``cpu``, ``cuda``, ``mps``).
    """

    def __init__(
        self,
        n_filters: int = 8,
        kernel_size: int = 6,
        pool_size: int = 2,
        hidden_units: int = 30,
        dropout: float = 0.2,
        lstm_output: str = "last",
        learning_rate: float = 0.01,
        l2_factor: float = 0.001,
        gradient_clip_val: float = 1.0,
        batch_size: int = 128,
        max_epochs: int = 100,
        accelerator: str = "auto",
        progress_bar: bool = False,
        random_state: int = 0,
        root_dir: str | None = None,
    ) -> None:
        self.n_filters = n_filters
        self.kernel_size = kernel_size
        self.pool_size = pool_size
        self.hidden_units = hidden_units
        self.dropout = dropout
        self.lstm_output = lstm_output
        self.learning_rate = learning_rate
        self.l2_factor = l2_factor
        self.gradient_clip_val = gradient_clip_val
        self.batch_size = batch_size
        self.max_epochs = max_epochs
        self.accelerator = accelerator
        self.progress_bar = progress_bar
        self.random_state = random_state
        self.root_dir = root_dir

    def check_params(self) -> dict:
        """The training loop's counts, ``batch_size`` and ``max_epochs``, as ints (a sweep's ``30.0`` is 30:
        Lightning and torch take ints only); raise naming the first setting with an impossible value.
        :func:`build_classifier` calls it before any data is built, :meth:`fit` again."""
        check_layer_settings(self.n_filters, self.kernel_size, self.pool_size, self.hidden_units, self.dropout,
                             self.lstm_output)
        counts = {"batch_size": whole_number("classifier.batch_size", self.batch_size),
                  "max_epochs": whole_number("trainer.max_epochs", self.max_epochs)}
        if not finite_number("classifier.learning_rate", self.learning_rate, "a positive number") > 0:
            raise BearingTwinError(f"classifier.learning_rate must be a positive number, got {self.learning_rate!r}")
        for key, value in (("classifier.l2_factor", self.l2_factor), ("trainer.gradient_clip_val", self.gradient_clip_val)):
            if value is not None and not finite_number(key, value, "a non-negative number") >= 0:
                raise BearingTwinError(f"{key} must be a non-negative number, got {value!r}")
        check_accelerator(self.accelerator)
        return counts

    def __sklearn_is_fitted__(self) -> bool:
        # fitted once the model is: a fit refused after its data were checked leaves n_features_in_ set
        return hasattr(self, "module_")

    def fit(self, X, y, eval_set: tuple | None = None) -> "CnnBiLstmClassifier":
        X, y = training_data(self, *_check_xy(X, y))
        counts = self.check_params()
        training_classes(y)  # one state: nothing to tell apart
        L.seed_everything(self.random_state, workers=True, verbose=False)
        self.classes_, y_index = np.unique(y, return_inverse=True)
        shape = CnnBiLstmShape(
            input_length=X.shape[1],
            n_classes=len(self.classes_),
            n_filters=self.n_filters,
            kernel_size=self.kernel_size,
            pool_size=self.pool_size,
            hidden_units=self.hidden_units,
            dropout=self.dropout,
            lstm_output=self.lstm_output,
        )
        self.scaler_ = StandardScaler().fit(X)
        val = None
        if eval_set is not None:
            X_val, y_val = _check_xy(*eval_set)
            unseen = np.setdiff1d(y_val, self.classes_)
            if unseen.size:  # searchsorted would score them as a neighbouring class
                raise BearingTwinError(f"eval_set holds label(s) {unseen.tolist()} that y does not: the network "
                                       "learns only the classes it is trained on")
            val = (self.scaler_.transform(X_val), np.searchsorted(self.classes_, y_val))
        data = SequenceDataModule(
            self.scaler_.transform(X), y_index, *(val or (None, None)), batch_size=counts["batch_size"], seed=self.random_state
        )
        self.module_ = CnnBiLstmModule(shape, learning_rate=self.learning_rate, l2_factor=self.l2_factor)
        with tempfile.TemporaryDirectory() as scratch, _quiet_lightning(), one_torch_thread():
            trainer = L.Trainer(
                max_epochs=counts["max_epochs"],
                gradient_clip_val=self.gradient_clip_val,
                accelerator=self.accelerator,
                devices=1,
                deterministic=True,
                logger=False,
                enable_checkpointing=False,
                enable_progress_bar=self.progress_bar is True,
                callbacks=[StderrProgressBar()] if self.progress_bar is True else [],
                enable_model_summary=False,
                num_sanity_val_steps=0,
                limit_val_batches=0 if eval_set is None else 1.0,
                default_root_dir=self.root_dir or scratch,
            )
            trainer.fit(self.module_, datamodule=data)
        self.device_ = trainer.strategy.root_device.type  # where auto took it: a GPU's arithmetic is not the CPU's
        self.module_.to("cpu").eval()
        self.history_ = list(self.module_.history)
        return self

    def predict_proba(self, X) -> np.ndarray:
        """Class probabilities (n_samples, n_classes), columns in ``classes_`` order."""
        X = prediction_data(self, _check_x(X))
        inputs = torch.as_tensor(self.scaler_.transform(X), dtype=torch.float32).unsqueeze(1)
        with torch.inference_mode(), one_torch_thread():
            return torch.softmax(self.module_(inputs), dim=1).numpy()

    def predict(self, X) -> np.ndarray:
        return self.predict_with_proba(X)[0]

    def predict_with_proba(self, X) -> tuple[np.ndarray, np.ndarray]:
        """Predicted classes and the probabilities behind them, from one forward pass."""
        probabilities = self.predict_proba(X)
        return self.classes_[probabilities.argmax(axis=1)], probabilities

    def save(self, path) -> dict:
        """Write the network's weights to ``path`` (torch ``state_dict``); returns the rest of the
        fitted state (parameters, layer sizes, classes, feature scaler) as JSON-able values."""
        torch.save(self.module_.state_dict(), path)
        params = {k: v for k, v in self.get_params().items() if k != "root_dir"}
        return {
            "params": params,
            "shape": asdict(self.module_.shape),
            "classes": self.classes_.tolist(),
            "scaler": {"mean": self.scaler_.mean_.tolist(), "scale": self.scaler_.scale_.tolist()},
            "weights": Path(path).name,
        }

    @classmethod
    def load(cls, path, state: dict) -> "CnnBiLstmClassifier":
        """The fitted classifier :meth:`save` wrote, on the CPU, in evaluation mode; no Trainer is involved."""
        classifier = cls(**state["params"])
        classifier.classes_ = np.asarray(state["classes"])
        classifier.scaler_ = StandardScaler()
        classifier.scaler_.mean_ = np.asarray(state["scaler"]["mean"])
        classifier.scaler_.scale_ = np.asarray(state["scaler"]["scale"])
        classifier.scaler_.var_ = classifier.scaler_.scale_ ** 2
        classifier.scaler_.n_features_in_ = classifier.n_features_in_ = classifier.scaler_.mean_.size
        module = CnnBiLstmModule(CnnBiLstmShape(**state["shape"]), classifier.learning_rate, classifier.l2_factor)
        module.load_state_dict(torch.load(path, map_location="cpu", weights_only=True))
        classifier.module_ = module.eval()
        classifier.history_ = []
        return classifier


class StderrProgressBar(TQDMProgressBar):
    """Lightning's epoch bar on stderr, beside the VMD bars: Lightning writes it to stdout, which
    a command keeps for its results (the closing summary)."""

    def init_train_tqdm(self):
        with contextlib.redirect_stdout(sys.stderr):  # Lightning reads sys.stdout when it builds the bar
            return super().init_train_tqdm()

    def init_validation_tqdm(self):
        with contextlib.redirect_stdout(sys.stderr):
            return super().init_validation_tqdm()


@contextlib.contextmanager
def one_torch_thread():
    """Run torch on one CPU thread, then restore the count. A CPU result depends on the number of threads
    (each splits its reductions differently: the main job's test accuracy was 96.67 % on two threads and
    95.56 % on one), so training and prediction take one on every machine, whatever its cores; for this
    network's sizes that costs no time (10.6 s against 10.7 s for the main job on two cores)."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(threads)


@contextlib.contextmanager
def _quiet_lightning():
    """Silence Lightning's per-fit banners (device summary, tips, 'max_epochs reached'): a sweep fits hundreds;
    and Lightning 2.6's own use of a torch API that torch 2.13 deprecates (``LeafSpec``), printed at every fit
    and nothing a user can act on."""
    lightning_log = logging.getLogger("lightning.pytorch")
    level = lightning_log.level
    lightning_log.setLevel(logging.WARNING)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=r".*isinstance\(treespec, LeafSpec\)` is deprecated")
            yield
    finally:
        lightning_log.setLevel(level)


def _check_x(X) -> np.ndarray:
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2:
        raise BearingTwinError(f"the classifier takes samples as rows of a 2-D array, got shape {X.shape}")
    if not np.all(np.isfinite(X)):
        raise BearingTwinError(f"the classifier input holds {np.count_nonzero(~np.isfinite(X))} NaN or infinite values")
    return X


def _check_xy(X, y) -> tuple[np.ndarray, np.ndarray]:
    # A column of labels is raveled here (with scikit-learn's DataConversionWarning, as its classifiers do) so that
    # labels of another length than X's are named below, before training_data would say so in scikit-learn's words.
    X, y = _check_x(X), np.asarray(y)
    if y.ndim == 2 and y.shape[1] == 1:
        y = column_or_1d(y, warn=True)
    if y.shape != (X.shape[0],):
        raise BearingTwinError(f"labels have shape {y.shape}, expected ({X.shape[0]},) for {X.shape[0]} samples")
    return X, y
