"""Plain data: the process model, measured parts, and loading them.

Nomenclature (lengths in the model unit unless stated):

``deviation``  measured actual − nominal of a dimension;
``lower``, ``upper``  tolerance limits as signed deviations from nominal;
``margin``  distance of a deviation to its nearer limit (negative when outside);
``correction``  change added to a register (WKS or tool length);
``predicted``  deviation expected after a correction.
"""

from setupfix.model.effects import EffectsSection
from setupfix.model.loader import load_model, model_from_dict
from setupfix.model.measurements import (
    CANONICAL_COLUMNS,
    LENGTH_COLUMNS,
    PartMeasurement,
    match_parts,
    suggest_names,
)
from setupfix.model.process import (
    Dimension,
    Feature,
    MachinePoint,
    ProcessModel,
    Register,
    normalise_name,
)
from setupfix.model.safety import RegisterPolicy, SafetySettings

__all__ = [
    "CANONICAL_COLUMNS",
    "LENGTH_COLUMNS",
    "Dimension",
    "EffectsSection",
    "Feature",
    "MachinePoint",
    "PartMeasurement",
    "ProcessModel",
    "Register",
    "RegisterPolicy",
    "SafetySettings",
    "load_model",
    "match_parts",
    "model_from_dict",
    "normalise_name",
    "suggest_names",
]
