"""Thermal-drift models: Grey GM(1,N)/GMC(1,N), lumped-mass + Kalman fusion, MRA.

Implements Abdulshahed, Longstaff & Fletcher (2017), *A cuckoo search optimisation-based
Grey prediction model for thermal error compensation on CNC machine tools*, and Wang,
Li, Cai & Wang (2017), *Thermal error modeling of the CNC machine tool based on data
fusion method of Kalman filter*.

Modules: :mod:`~setupfix.thermal.grey` (pure Grey functions), :mod:`~.calibrate`
(CS, PSO, GA), :mod:`~.lumped` (lumped-mass model), :mod:`~.kalman` (scalar filter),
:mod:`~.mra`, :mod:`~.metrics`, :mod:`~.estimator`, :mod:`~.grey_model`, :mod:`~.kalman_model` (estimator classes),
:mod:`~.simulator`, :mod:`~.registry` (methods by name), :mod:`~.persist` (saved form),
:mod:`~.feedforward` (drift fed forward into corrections).  Temperature logs are read
by :mod:`parsers.temperature`; model files by :mod:`setupfix.inputs.thermal_files`.
"""

from __future__ import annotations

from setupfix.thermal.estimator import MRAModel, ThermalModel
from setupfix.thermal.grey_model import GreyModel
from setupfix.thermal.kalman_model import KalmanFusionModel

__all__ = ["GreyModel", "KalmanFusionModel", "MRAModel", "ThermalModel"]
