"""A described mechanism as plain, validated data (what :mod:`.schema` makes of
the config's ``mechanism:`` mapping): expression trees for every point, axis,
length and mass, with the legs' symmetric patterns expanded."""
from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["ParamDecl", "PoseSpec", "PlatformSpec", "LegSpec", "Description"]


@dataclass(frozen=True)
class ParamDecl:
    name: str
    kind: str
    design: bool
    default: float | None
    doc: str = ""


@dataclass(frozen=True)
class PoseSpec:
    type: str
    names: tuple[str, ...]            # the config's pose coordinate names, in order
    roles: tuple[str, ...]            # the rigid-body coordinate (ROLES) of each
    fixed: dict                       # role -> tree, angles that are not coordinates (rotation)
    centre: tuple                     # 3 trees: the fixed centre (rotation) / offset of the platform frame
    home: tuple[float, ...]           # a pose every named design must reach (SI)
    jacobian: str                     # "rates" or "angular_velocity"

    @property
    def dof(self) -> int:
        return len(self.names)


@dataclass(frozen=True)
class PlatformSpec:
    mass: tuple | None                # tree
    inertia: tuple                    # 3 x 3 trees (platform frame, about the centre of mass)
    com: tuple                        # 3 trees (platform frame)


@dataclass(frozen=True)
class LegSpec:
    """One leg (after the pattern is expanded).  Vectors are 3 trees in the
    leg's own frame; ``turn_base`` / ``turn_platform`` rotate them about z."""

    path: str                         # key path of the leg's group (for messages)
    actuator: str
    kind: str
    base: tuple
    platform: tuple
    direction: tuple | None           # prismatic: direction; revolute: axis
    reference: tuple | None           # revolute: crank direction at q = 0
    crank: tuple | None               # revolute: crank length
    rod: tuple | None                 # rod length (prismatic, revolute)
    turn_base: tuple
    turn_platform: tuple
    branch: str | None
    bodies: dict = field(default_factory=dict)   # name -> tree (masses, inertias, centres)
    across: tuple | None = None       # rod.across vector (parallelogram width direction)


@dataclass(frozen=True)
class Description:
    label: str
    params: tuple[ParamDecl, ...]
    pose: PoseSpec
    platform: PlatformSpec
    gravity: tuple
    legs: tuple[LegSpec, ...]
    has_dynamics: bool

    @property
    def actuator_names(self) -> tuple[str, ...]:
        return tuple(leg.actuator for leg in self.legs)
