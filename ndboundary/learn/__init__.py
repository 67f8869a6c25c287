"""Learning with relaxed boundaries: the level-set classifier and label propagation."""

from .classifier import LevelSetClassifier
from .poisson import poisson_labels
from .propagation import harmonic_labels, vote

__all__ = ["LevelSetClassifier", "harmonic_labels", "poisson_labels", "vote"]
