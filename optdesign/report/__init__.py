"""The reports: what a run folder (or many) says to a reader, from the data on disk.

* :mod:`.md` -- results.md, optimum.yaml and the top-level history and
  population CSV files of a finished run (with :mod:`.certificates` and
  :mod:`.integrals`, its sections);
* :mod:`.png` -- the run's plots (convergence.png, pareto.png);
* :mod:`.html` -- the interactive report.html of a run and the comparison page;
* :mod:`.summary` -- the summary of a batch: rows read back from run folders,
  statistics across seeds, its CSV and Markdown tables and plot (with
  :mod:`.folders`: a folder's config, a batch run's keys and labels);
* :mod:`.atlas` and :mod:`.atlas_plot` -- index atlases of one design (CSV and PNG).

Above the optimizer's results (plain data: results.json, the CSV files) and
below the commands; :mod:`optdesign.runner` hands :mod:`.md` and :mod:`.html`
to a run.  Nothing here imports :mod:`optdesign.optimize` or :mod:`optdesign.studies`.
"""
