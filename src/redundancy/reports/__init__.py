"""Reports: one set of sections, formatted as the lesson's tables and judged by the audit.

* :mod:`~redundancy.reports.sections`: the joint table, keyframes, gravity budget and
  self-collision statistics, each computed once (sweeps in chunks) from the Arm, the batched
  analyses and the collision package;
* :mod:`~redundancy.reports.lesson`: lesson 5.2's six tables (formats the sections; tables
  (5) and (6) simulate through :mod:`redundancy.lab.control`);
* :mod:`~redundancy.reports.audit`: the audit: the sections, the engines' agreement, and the
  findings, as frozen dataclasses and as JSON;
* :mod:`~redundancy.reports.tables`: text tables whose columns are sized to their content;
* :mod:`~redundancy.reports.files`: writing a report file (regular files only, atomically).

No module here calls MuJoCo or Pinocchio for kinematics or dynamics.
"""
