"""Studies as files (``ringsim study``, docs/studies.md): a study file names a base scenario,
its cases, seeds, ratios and method variants; the command runs every run once (reusing,
resuming and lengthening run files like a sweep), keeps a small JSON summary of each run
beside the study file, and writes the report from those summaries alone.

* ``runs``: a run's identity (the hash of its resolved scenario), its summary, the plan and
  the worker;
* ``report``: the numbers of ``report.json``;
* ``markdown``: ``report.md``;
* ``command``: ``run_study`` and the command line.

The study file itself is read by ``ringsim.config.study``.
"""

from ringsim.study.command import StudyResult, default_output_dir, run_study, study_command

__all__ = ["StudyResult", "default_output_dir", "run_study", "study_command"]
