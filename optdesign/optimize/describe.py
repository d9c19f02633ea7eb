"""A stage's best so far and its finished result in a few words (its lines
in the progress), in the config's units."""
from __future__ import annotations

from ..units import Units

__all__ = ["describe_row", "describe_result"]


def describe_row(units: Units, st, rec: dict) -> str:
    """A stage's best so far, for its progress line: the index in its own
    sense and unit, the weighted sum f, or the size of the front."""
    from ..units import index_text

    if st.kind == "single" and f"best_{st.index}" in rec:
        return index_text(units, st.index, rec[f"best_{st.index}"], 4)
    if st.kind == "weighted":
        return _f_text(rec["best_objective"])
    if "front_size" in rec:
        return f"{rec['front_size']} non-dominated"
    return ""


def _f_text(f: float) -> str:
    return "f = 0 (round-off)" if abs(f) < 1e-12 else f"f = {f:.4g}"


def describe_result(units: Units, st, res: dict) -> str:
    """A finished stage's result in a few words (its line in the progress)."""
    from ..units import index_text

    if st.kind == "single" and res.get("value") is not None:
        return index_text(units, st.index, res["value"], 4)
    if st.kind == "weighted" and res.get("objective") is not None:
        return _f_text(res["objective"])
    if st.kind == "pareto":
        return f"{res.get('front_size', '?')} non-dominated"
    if st.kind == "extremes" and "runs" in res:
        return f"{len(res['runs'])} extremes polished from {res.get('feasible_designs', '?')} feasible designs"
    if st.kind == "prescan" and "feasible_designs" in res:
        return f"{res['feasible_designs']} of {res.get('evaluations', '?')} designs feasible"
    return ""
