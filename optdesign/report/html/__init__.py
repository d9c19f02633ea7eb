"""The interactive HTML report of run folders (plotly, self-contained).

``write_report_html(folder)`` writes ``report.html`` into a finished run
folder from what is on disk; ``write_compare_html(folders, out)`` one page
setting several runs side by side.  Both read only data (JSON, CSV, the
config's YAML through the safe loader) and write only the file they name.
"""
from .compare import write_compare_html
from .report import REPORT_NAME, build_report, write_report_html

__all__ = ["write_report_html", "write_compare_html", "build_report", "REPORT_NAME"]
