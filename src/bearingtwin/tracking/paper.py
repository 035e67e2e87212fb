"""The paper's published figures (Ma & Zhu, Symmetry 2025, 17, 1494), the only place they live.

Reports print them beside ours. Values are as printed in the paper: accuracies in
percent, Table 3's precision / recall / F1 as fractions. Method keys are
``<features>+<classifier>`` config choices, as our runs are tagged.
"""

from __future__ import annotations

PROPOSED = "sabo_vmd_pemie+cnn_bilstm"

# Table 3: per-class metrics of a representative run of the proposed method on simulated data.
TABLE3 = {
    "normal": {"precision": 1.000, "recall": 0.933, "f1": 0.965},
    "inner": {"precision": 1.000, "recall": 1.000, "f1": 1.000},
    "ball": {"precision": 1.000, "recall": 1.000, "f1": 1.000},
    "outer": {"precision": 0.938, "recall": 1.000, "f1": 0.968},
}

# Section 4.1: the proposed method over five random seeds, and the mean +- std the paper gives
# (population standard deviation: 0.41 is what ddof=0 gives for these five values).
SEED_ACCURACIES = (98.33, 98.88, 98.88, 97.78, 98.33)
ACCURACY_MEAN = 98.44
ACCURACY_STD = 0.41

# Table 4: accuracy of the four methods (one run each).
TABLE4 = {
    PROPOSED: 98.33,
    "raw+cnn_bilstm": 86.67,
    "sabo_vmd_minen+cnn_bilstm": 93.89,
    "sabo_vmd_pemie+svm": 96.67,
}
TABLE4_NAMES = {
    PROPOSED: "SABO-VMD-CNN-BiLSTM (PE-MIE)",
    "raw+cnn_bilstm": "CNN-BiLSTM (raw signals)",
    "sabo_vmd_minen+cnn_bilstm": "SABO-VMD (minEn)-CNN-BiLSTM",
    "sabo_vmd_pemie+svm": "SABO-VMD-SVM (PE-MIE)",
}

# Section 4.2: the proposed method on the HUST data set, by shaft speed in Hz.
HUST = {60: 95.00, 65: 97.78, 70: 99.44}
HUST_CLASSES = {"normal": "H", "inner": "0.5X_I", "ball": "0.5X_B", "outer": "0.5X_O"}
"""The files (name stems) of its four classes: healthy and the medium (0.5X_) faults, as Table 5 uses them."""
HUST_CHANNEL = "X"
"""The accelerometer axis it reads."""
