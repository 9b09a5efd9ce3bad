"""Reports: one set of sections, judged by the audit and formatted as arm7's example tables.

* `sections`: the joint table, keyframes, gravity budget and self-collision statistics, each
  computed once (sweeps in chunks) from the Arm, the batched analyses and the collision package;
  `pose_sections` holds the two taken pose by pose (the joint table, a row per keyframe);
* `lesson`: the worked example ``redundancy example arm7``, lesson 5.2's six tables for arm7
  (formats the sections; tables (5) and (6) simulate through `redundancy.lab.control`);
* [`audit`][redundancy.reports.audit]: the audit: the sections, the engines' agreement, and the
  findings, as frozen dataclasses and as JSON;
* `tables`: text tables sized by ``rich``, lines within 100 characters;
* `progress`: the progress bar on a terminal;
* `files`: writing a report file (regular files only, atomically).

No module here calls MuJoCo or Pinocchio for kinematics or dynamics.
"""
