"""A self-contained HTML page: plotly.js embedded once in the head, figures as
divs that reuse it, a content-security policy that forbids any network access
at view time, and a small script that reports figures that failed to draw."""
from __future__ import annotations

import itertools

import plotly.io as pio

from .figures import esc

__all__ = ["Page", "PLOTLY_CONFIG", "MODEBAR_PX", "clear_of_modebar"]

#: the strip at the top of a figure that plotly's toolbar (modebar) takes
MODEBAR_PX = 34

PLOTLY_CONFIG = {"displaylogo": False, "responsive": True,
                 "toImageButtonOptions": {"format": "png", "scale": 2}}

#: nothing is fetched: scripts and styles are inline, images data: or blob: URLs
_CSP = ("default-src 'none'; script-src 'unsafe-inline' 'unsafe-eval'; style-src 'unsafe-inline'; "
        "img-src data: blob:; font-src data:; worker-src blob:; connect-src 'none'")

_CSS = """
:root { --fg:#1d1d1f; --muted:#666; --line:#ddd; --accent:#1f5f9f; }
* { box-sizing: border-box; }
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, Helvetica, Arial, sans-serif; color: var(--fg);
       margin: 0; line-height: 1.45; background: #fafafa; }
main { max-width: 1240px; margin: 0 auto; padding: 18px 28px 40px; background: white; }
header h1 { margin: 4px 0 2px; font-size: 26px; }
header p { margin: 4px 0; color: var(--muted); }
nav { position: sticky; top: 0; background: rgba(255,255,255,0.96); border-bottom: 1px solid var(--line);
      padding: 6px 0; margin: 10px 0 0; z-index: 10; font-size: 14px; }
nav a { color: var(--accent); text-decoration: none; margin-right: 16px; white-space: nowrap; }
h2 { font-size: 20px; margin: 30px 0 8px; padding-top: 6px; border-top: 2px solid #eee; }
h3 { font-size: 16px; margin: 20px 0 6px; }
p.note, .note { color: var(--muted); font-size: 13.5px; }
.tablewrap { overflow-x: auto; margin: 6px 0 10px; }
table { border-collapse: collapse; font-size: 13.5px; }
th, td { border-bottom: 1px solid var(--line); padding: 4px 10px; text-align: left; vertical-align: top; }
th { background: #f3f5f8; font-weight: 600; white-space: nowrap; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
table.norm td:nth-child(5), table.norm td:nth-child(7) { white-space: normal; font-size: 12.5px; }
p.cert.bad { color: #b00020; font-weight: 600; } p.cert.warn { color: #8a5a00; } p.cert.ok { color: #1b5e20; }
table.kv td:first-child { font-weight: 600; white-space: nowrap; }
table.kv td { white-space: normal; }
.muted { color: var(--muted); }
code { font-size: 0.95em; background: #f3f3f3; padding: 0 3px; border-radius: 3px; }
.fig { border: 1px solid #eee; border-radius: 4px; margin: 10px 0 16px; }
.grid2 { display: grid; grid-template-columns: repeat(auto-fill, minmax(520px, 1fr)); gap: 6px 14px; }
.key { font-size: 16px; }
#report-errors { display: none; background: #fdecea; border: 1px solid #e0a8a1; color: #8a1f11; padding: 8px 12px;
                 margin: 10px 0; border-radius: 4px; white-space: pre-wrap; }
footer { margin-top: 30px; color: var(--muted); font-size: 12.5px; border-top: 1px solid var(--line); padding-top: 8px; }
"""

#: collects script errors (and blocked network requests) before plotly.js loads
_ERRORS_HEAD = """
window.__reportErrors = [];
window.addEventListener('error', function (e) { window.__reportErrors.push('error: ' + (e.message || e.type)); });
window.addEventListener('unhandledrejection', function (e) {
  window.__reportErrors.push('unhandled rejection: ' + (e.reason && e.reason.message ? e.reason.message : e.reason)); });
document.addEventListener('securitypolicyviolation', function (e) {
  window.__reportErrors.push('blocked: ' + e.violatedDirective + ' ' + e.blockedURI); });
(function () { var ce = console.error; console.error = function () {
  window.__reportErrors.push('console.error: ' + Array.prototype.join.call(arguments, ' '));
  return ce.apply(console, arguments); }; })();
"""

#: after every figure: say how many drew, and show any error on the page
_ERRORS_TAIL = """
(function () {
  function done() {
    var n = document.querySelectorAll('.js-plotly-plot').length;
    var errs = window.__reportErrors;
    document.body.setAttribute('data-figures-drawn', String(n));
    document.body.setAttribute('data-errors', String(errs.length));
    if (errs.length) {
      var box = document.getElementById('report-errors');
      box.textContent = 'A script failed while drawing this page; some figures may be missing:\\n' + errs.join('\\n');
      box.style.display = 'block';
    }
  }
  if (document.readyState === 'complete') { done(); } else { window.addEventListener('load', done); }
})();
"""


class Page:
    """Sections of HTML and figures, rendered into one document."""

    def __init__(self, title: str):
        self.title = title
        self.parts: list[str] = []
        self.nav: list[tuple[str, str]] = []
        self.figures = 0
        self._ids = itertools.count(1)

    def section(self, anchor: str, heading: str) -> None:
        self.nav.append((anchor, heading))
        self.parts.append(f'<h2 id="{anchor}">{esc(heading)}</h2>')

    def html(self, s: str) -> None:
        self.parts.append(s)

    def figure(self, fig, cls: str = "fig") -> str:
        """The div of a figure (plotly.js itself is in the head, once), its
        title below the toolbar's strip (:func:`clear_of_modebar`)."""
        self.figures += 1
        clear_of_modebar(fig)
        div = pio.to_html(fig.to_dict(), full_html=False, include_plotlyjs=False, include_mathjax=False,
                          config=PLOTLY_CONFIG, div_id=f"fig{next(self._ids)}", default_width="100%",
                          default_height=f"{int(fig.layout.get('height') or 450)}px", validate=False,
                          auto_play=False)   # a figure with frames (a slider) opens on its first frame
        return f'<div class="{cls}">{div}</div>'

    def add_figure(self, fig) -> None:
        self.parts.append(self.figure(fig))

    def render(self, header: str, footer: str) -> str:
        from plotly.offline import get_plotlyjs

        nav = "".join(f'<a href="#{a}">{esc(h)}</a>' for a, h in self.nav)
        return "\n".join([
            "<!DOCTYPE html>",
            '<html lang="en"><head><meta charset="utf-8">',
            f'<meta http-equiv="Content-Security-Policy" content="{_CSP}">',
            '<meta name="viewport" content="width=device-width, initial-scale=1">',
            f"<title>{esc(self.title)}</title>",
            f"<style>{_CSS}</style>",
            f"<script>{_ERRORS_HEAD}</script>",
            f'<script type="text/javascript">{get_plotlyjs()}</script>',
            "</head><body><main>",
            header,
            f"<nav>{nav}</nav>",
            '<div id="report-errors"></div>',
            *self.parts,
            f"<footer>{footer}</footer>",
            "</main>",
            f"<script>{_ERRORS_TAIL}</script>",
            "</body></html>",
        ])


def clear_of_modebar(fig):
    """A titled figure's title anchored at the figure's top, ``MODEBAR_PX``
    below it: the toolbar (top right, shown on hover) no longer covers it.
    The top margin and the height grow by as much (the plot keeps its size)."""
    lay = fig.layout
    t = lay.get("title", {})
    done = t.get("yref") == "container" and t.get("pad", {}).get("t") == MODEBAR_PX
    if not t.get("text") or done:   # none, or done
        return fig
    top = lay.get("margin", {}).get("t")
    if top is None:
        top = lay.get("template", {}).get("layout", {}).get("margin", {}).get("t")
        top = 80 if top is None else top
    fig.update_layout(title=dict(yref="container", y=1.0, yanchor="top", pad=dict(t=MODEBAR_PX)),
                      margin=dict(t=int(top) + MODEBAR_PX), height=int(lay.get("height") or 450) + MODEBAR_PX)
    return fig


def plotly_js_version() -> str:
    import plotly

    try:
        from plotly.offline import get_plotlyjs_version

        return get_plotlyjs_version()
    except ImportError:  # pragma: no cover
        return f"bundled with plotly {plotly.__version__}"
