"""The 3-P(4S) translational vibration table (seed paper 001): the numpy model
(:mod:`.model`, the reference), its compiled path (:mod:`.compiled`: the one
engine on the mechanism's description) and its MuJoCo check (:mod:`.mujoco`)."""
from .dynamics import mass_coefficients, platform_mass, solve_T
from .geometry import E, T, Z, skew
from .model import P4S, PAPER_MASSES
from .symbolic import symbolic_model

__all__ = ["P4S", "E", "T", "Z", "PAPER_MASSES", "skew", "mass_coefficients", "platform_mass", "solve_T",
           "symbolic_model"]
