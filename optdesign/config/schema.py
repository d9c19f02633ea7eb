"""The validated configuration as plain typed objects (all values SI)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..units import DesignVariable, Units
from ..workspace import WorkspaceSpec
from .checks import ChecksSpec
from .keys import OPTIMIZER, spec_class
from .reader import ConfigError

__all__ = ["Config", "DesignVariable", "IndexSpec", "OptimizerSpec", "WorkspaceSpec"]


@dataclass(frozen=True)
class IndexSpec:
    """A performance index as the config names it."""

    name: str
    kind: str
    convention: str | None
    sense: str  # "min" or "max"
    options: dict = field(default_factory=dict)


#: settings of the stages (see optdesign.optimize): one field per key of
#: :data:`.keys.OPTIMIZER` (``pareto.population`` -> ``pareto_population``), its default the table's
OptimizerSpec = spec_class("OptimizerSpec", OPTIMIZER,
                           "Settings of the stages, the searches and the Pareto runs (docs/config.md, optimizer).",
                           __name__)


@dataclass
class Config:
    """A validated configuration.  All values are SI."""

    source: str
    mechanism: str
    name: str
    parameters: dict[str, float]
    design_variables: dict[str, DesignVariable]
    designs: dict[str, dict[str, float]]
    workspace: WorkspaceSpec
    indices: dict[str, IndexSpec]
    optimizer: OptimizerSpec
    reference: dict[str, dict[str, float]]
    raw: dict
    #: the mechanism class (a registered one, or one built from a description)
    mechanism_class: Any = field(default=None, repr=False, compare=False)
    #: the text of the file as read (None for a config built from a mapping)
    text: str | None = field(default=None, repr=False, compare=False)
    #: how hard a run checks its reported designs (certificates, integrals)
    checks: ChecksSpec = field(default_factory=ChecksSpec)

    @property
    def free_variables(self) -> list[DesignVariable]:
        return [v for v in self.design_variables.values() if v.free]

    def design(self, name: str) -> dict[str, float]:
        if name not in self.designs:
            raise ConfigError(self.source, "designs", f"no design named {name!r}; the config has {', '.join(self.designs) or 'none'}")
        return dict(self.designs[name])

    def check_optimizable(self, pareto: bool = True) -> None:
        """Raise ConfigError unless an optimization of this config can start: at
        least one free design variable, and the workspace points times the
        largest population within the evaluation limit (checked before a run
        folder is made, so a rejected config leaves nothing on disk)."""
        from ..workspace import MAX_POINTS, point_count

        if not self.free_variables:
            raise ConfigError(self.source, "design_variables",
                              "no free design variable: give at least one 'bounds' with lower < upper")
        n = point_count(self.workspace, tuple(self.mechanism_class.pose_names))
        opt = self.optimizer
        key, pop = "optimizer.population", opt.population
        if pareto and opt.pareto_algorithms and opt.pareto_population > pop:
            key, pop = "optimizer.pareto.population", opt.pareto_population
        if n * pop > MAX_POINTS:
            raise ConfigError(self.source, key, f"{pop:,} designs x {n:,} workspace points = {n * pop:,} evaluations "
                                                f"per generation call; expected at most {MAX_POINTS:,} (a smaller "
                                                "population or fewer workspace points)")

    def initial_design(self) -> dict[str, float]:
        return {k: v.value for k, v in self.design_variables.items()}

    def units(self) -> Units:
        """What a user sees of this config's quantities (:class:`optdesign.units.Units`):
        the plain table the layers below the commands are handed instead of the config."""
        from ..mechanisms import get

        cls = self.mechanism_class if self.mechanism_class is not None else get(self.mechanism)
        return Units.of(cls, self.parameters, self.design_variables, self.indices, self.workspace.unit)
