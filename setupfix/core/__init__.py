"""Core of every layer: the error hierarchy, length units, atomic file output and validated hyper-parameters."""
