"""A described mechanism as plain, validated data (what :mod:`.schema` makes of
the config's ``mechanism:`` mapping): expression trees for every point, axis,
length and mass, with the legs' symmetric patterns expanded."""
from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["ParamDecl", "PoseSpec", "PlatformSpec", "LegSpec", "JointSpec", "ChainSpec", "Description"]


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
    #: chain descriptions: indices (into names) of the independent coordinates, in
    #: the order given; the others are parasitic (None: every coordinate is independent)
    independent: tuple | None = None
    #: a declared coordinate map: the independent coordinates' names (new ones), a
    #: tree per independent pose coordinate (in ``independent``'s order) of them,
    #: and their SI units ("m", "rad" or "1"); None: the pose coordinates themselves
    coords: tuple | None = None
    cmap: tuple | None = None
    units: tuple = ()

    @property
    def dof(self) -> int:
        return len(self.names)

    @property
    def independent_index(self) -> tuple[int, ...]:
        return self.independent if self.independent is not None else tuple(range(len(self.names)))

    @property
    def parasitic_index(self) -> tuple[int, ...]:
        ind = set(self.independent_index)
        return tuple(i for i in range(len(self.names)) if i not in ind)


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
class JointSpec:
    """One joint of a chain leg (vectors: 3 trees in the leg's own frame, base
    frame at the chain's reference configuration, all joint values 0)."""

    path: str                         # key path (mechanism.legs[i].joints[j])
    type: str                         # R, P, U, S, C, Pa
    axis: tuple | None                # R, P, C, Pa: the axis; U: the first axis
    axis2: tuple | None               # U: the second axis
    at: tuple                         # a point of the axis (S: its centre)
    side: tuple | None                # Pa: the side vector, proximal pivot -> distal pivot
    actuated: int | None              # index of the actuated variable of this joint, or None
    home: tuple                       # trees, one per variable: start of the home Newton
    offset: tuple                     # trees, one per variable: the value at the reference configuration
    body: dict                        # the link after the joint: mass, centre (3 trees), inertia (3 x 3 trees)

    @property
    def nvar(self) -> int:
        return {"R": 1, "P": 1, "Pa": 1, "U": 2, "C": 2, "S": 3}[self.type]


@dataclass(frozen=True)
class ChainSpec:
    """A leg written as a serial chain of joints, base to platform."""

    path: str                         # key path of the leg's group
    actuator: str | None              # None: a passive (constraining) leg
    joints: tuple                     # JointSpec, base to platform
    platform: tuple                   # the platform point (platform frame) of the last joint
    turn_base: tuple
    turn_platform: tuple

    @property
    def closure(self) -> str:
        """``position`` (the chain ends in an S: its centre meets the platform
        point) or ``frame`` (the last link is fixed to the platform)."""
        return "position" if self.joints[-1].type == "S" else "frame"


@dataclass(frozen=True)
class Description:
    label: str
    params: tuple[ParamDecl, ...]
    pose: PoseSpec
    platform: PlatformSpec
    gravity: tuple
    legs: tuple[LegSpec, ...]
    has_dynamics: bool
    #: chain legs (kind: chain); with them, ``legs`` holds the shorthand legs only
    chains: tuple = ()
    #: chain descriptions: (actuator name, "leg" or "chain", index) in the description's order
    actuators: tuple = ()

    @property
    def is_chain(self) -> bool:
        """A description of the chain class (a chain leg or declared parasitic coordinates)."""
        return bool(self.chains) or self.pose.independent is not None

    @property
    def actuator_names(self) -> tuple[str, ...]:
        if self.actuators:
            return tuple(a for a, _, _ in self.actuators)
        return tuple(leg.actuator for leg in self.legs)
