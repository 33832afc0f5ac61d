"""Identifying an arm's dynamic parameters from data.

The joint torques are linear in the standard parameters (:mod:`~model.identification.parameters`):
``tau = Y(q, qd, qdd) pi`` with the compiled regressor of :mod:`~model.identification.regressor`.
:mod:`~model.identification.base` finds the identifiable combinations (the base parameters),
:mod:`~model.identification.excitation` a trajectory that excites them well,
:mod:`~model.identification.signals` turns a measured log into regression samples,
:mod:`~model.identification.estimation` fits them (ordinary and weighted least squares, and a physically
consistent fit), :mod:`~model.identification.identify` runs the whole pipeline with a held-out part, and
:mod:`~model.identification.robot_file` writes the result as a robot file.

>>> import model
>>> from model.identification import Regressor, base_parameters
>>> reg = Regressor(model.load_description("planar2r"))
>>> base_parameters(reg).n_base        # 6 inertial + 1 rotor + 3 x 2 friction and offset
13
"""

from .base import BaseParameters, base_parameters
from .estimation import Fit, consistent_fit, least_squares, regression
from .excitation import ExcitationLimits, ExcitationResult, FourierTrajectory, excitation_limits, optimise_excitation
from .identify import FitErrors, Identification, identify, identify_log
from .parameters import parameter_names, pseudo_inertia, standard_parameters
from .regressor import Regressor
from .robot_file import identified_description, write_identified
from .signals import Preprocessing, Samples, cutoff_from_spectrum, prepare_samples

__all__ = [
    "BaseParameters",
    "ExcitationLimits",
    "ExcitationResult",
    "Fit",
    "FitErrors",
    "FourierTrajectory",
    "Identification",
    "Preprocessing",
    "Regressor",
    "Samples",
    "base_parameters",
    "consistent_fit",
    "cutoff_from_spectrum",
    "excitation_limits",
    "identified_description",
    "identify",
    "identify_log",
    "least_squares",
    "optimise_excitation",
    "parameter_names",
    "prepare_samples",
    "pseudo_inertia",
    "regression",
    "standard_parameters",
    "write_identified",
]
