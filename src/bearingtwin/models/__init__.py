"""Classifiers with a scikit-learn interface: the CNN-BiLSTM (Lightning) and an SVM pipeline."""
