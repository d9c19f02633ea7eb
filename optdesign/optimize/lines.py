"""Terminal lines of the progress display: fields joined within a width, cut
at field boundaries (never inside a number or a word), notices folded at
spaces, clocks (``m:ss``)."""
from __future__ import annotations

__all__ = ["fit_line", "wrap_line", "stage_line", "clock"]


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def _clock(s: float) -> str:
    s = max(0, int(round(s)))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


def _cut_words(text: str, width: int) -> str:
    """``text`` within ``width`` characters, cut at a word boundary (a space
    or '_') with …, never inside a word or a number."""
    if len(text) <= width:
        return text
    if width <= 1:
        return "…"[:max(0, width)]
    head = text[: width - 1]
    cut = max(head.rfind(" "), head.rfind("_"))
    if cut <= 0:
        return "…"
    return head[:cut].rstrip(" _/") + "…"


def fit_line(parts: list[str], width: int, shrink: int | None = 0, drop=None, drop_first=()) -> str:
    """Join ``parts`` (fields) with spaces within ``width`` characters, never
    cutting inside a field's number or word: the part at index ``shrink`` (a
    label; None: none) is shortened first, at a word boundary (with …); then whole parts
    are left out, in the order ``drop`` (indices; default: from the last one
    back to the second); at last the first part is cut at a word boundary.
    ``drop_first``: parts left out before the label is shortened."""
    parts = [p or "" for p in parts]

    def joined(ps):
        return " ".join(p for p in ps if p)

    line = joined(parts)
    for i in drop_first:
        if len(line) <= width:
            return line
        parts[i] = ""
        line = joined(parts)
    if len(line) <= width:
        return line
    if shrink is not None and parts[shrink]:
        over = len(line) - width
        parts[shrink] = _cut_words(parts[shrink], max(1, len(parts[shrink]) - over))
        if parts[shrink] == "…":
            parts[shrink] = ""
        line = joined(parts)
    order = list(drop) if drop is not None else list(range(len(parts) - 1, 0, -1))
    for i in order:
        if len(line) <= width:
            break
        parts[i] = ""
        line = joined(parts)
    return line if len(line) <= width else _cut_words(line, width)


def wrap_line(text: str, width: int) -> list[str]:
    """A line of its own folded to ``width`` at spaces (a word longer than the
    width is cut at a word boundary), continuation lines indented."""
    import textwrap

    lines = textwrap.wrap(text, max(8, width), subsequent_indent="  ", break_long_words=False,
                          break_on_hyphens=False) or [""]
    return [ln if len(ln) <= width else _cut_words(ln, width) for ln in lines]


def stage_line(label: str, gen: int, total: int, best: str, elapsed: float, width: int) -> str:
    """``label [####....] gen/total best 0:12`` within ``width`` characters (the
    bar shrinks, then it is left out, then the label is shortened at a word
    boundary; then the clock and the best value are left out whole)."""
    tail = f"{gen}/{total}"
    rest = [label, "", tail, best, _clock(elapsed)]
    room = width - len(" ".join(p for p in rest if p)) - 3
    bar_w = max(4, min(24, room))
    k = int(bar_w * gen / max(total, 1))
    rest[1] = f"[{'#' * k}{'.' * (bar_w - k)}]"
    return fit_line(rest, width, drop=[4, 3, 2], drop_first=[1])


clock = _clock
