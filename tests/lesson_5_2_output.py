"""Lesson 5.2's printed tables, copied verbatim from shared/lesson-5.2-output.txt.

Source: course lesson 5.2 "seven-dof", its script's printed output (the six tables). Kept here
so that the tests run in a clone without ../shared; tests/test_lesson.py also checks this copy
against the shared file whenever it is present.
"""

OUTPUT = """\
(1) joints, inertia and the explicit-damping timestep bound:
  joint axis    range (rad)  armature  damping  limit     M_ii  M_ii bare     h_max       bare
  j1       z    [-2.9  2.9]     0.050     0.50     80   1.0659    1.01592 473.74 ms  451.52 ms
  j2       y    [-1.8  1.8]     0.050     0.50     80   1.6672    1.61723 740.99 ms  718.77 ms
  j3       z    [-2.9  2.9]     0.050     0.50     60   0.4674    0.41735 207.71 ms  185.49 ms
  j4       y    [-0.1  2.9]     0.050     0.50     60   0.4700    0.42002 208.90 ms  186.68 ms
  j5       z    [-2.9  2.9]     0.050     0.50     20   0.0546    0.00461  24.27 ms    2.05 ms
  j6       y    [-2.2  2.2]     0.050     0.50     20   0.0549    0.00487  24.39 ms    2.17 ms
  j7       z    [-2.9  2.9]     0.050     0.50     10   0.0502    0.00024  22.33 ms    0.11 ms
  units: limit N m, M_ii kg m^2 at the home pose; h_max = 2 M_ii / (kd - b) for a controller
  damping kd = 5.0 N m s/rad on top of the joint's own damping b, which Euler treats implicitly
(2) singular values of the 6x7 Jacobian of the ee site:
  zero  singular values [2.0666 2.     0.498  0.     0.     0.    ]  rank 3  manipulability sqrt(det(J J^T)) = 0.00e+00
  home  singular values [1.85   1.8247 1.0681 0.4078 0.35   0.2332]  rank 6  manipulability sqrt(det(J J^T)) = 1.20e-01
(3) gravity torque against motor limits:
  10000 random poses within the ranges: largest gravity torque per joint (N m) [ 0.   42.47 11.63 11.78  0.48  0.49  0.  ]
  motor limit / largest gravity torque: - 1.88 5.16 5.09 41.26 41.19 -  (- : vertical axis, gravity never loads it)
  poses where some joint's gravity torque exceeds its motor limit: 0
(4) self-collision:
  10000 random poses: 15.5% have at least one self-contact
    link2 / link4            1550 poses
    flange / link2           282 poses
    flange / link1           250 poses
    link2 / link5            185 poses
  contacts at the zero pose: 0
  contacts at the home pose: 0
(5) hold the home pose for 2 s at h = 2 ms after a 0.01 rad/s nudge (PD: kp 100, kd 5):
  gravity compensation only    armature 0.0   Euler         max |qvel|    0.0108 rad/s at j1, bad-acceleration warnings 0
    same, eulerdamp disabled   armature 0.0   Euler         max |qvel|  1.59e+06 rad/s at j7, bad-acceleration warnings 1
  joint PD                     armature 0.05  Euler         max |qvel|    0.0104 rad/s at j1, bad-acceleration warnings 0
  joint PD                     armature 0.0   Euler         max |qvel|      15.2 rad/s at j7, bad-acceleration warnings 0
  joint PD                     armature 0.0   implicitfast  max |qvel|      15.2 rad/s at j7, bad-acceleration warnings 0
(6) the bare wrist's stability threshold in kd (no armature, Euler, h = 2 ms):
  bare j7: I = 0.000240 kg m^2, b = 0.5 N m s/rad, h = 0.002 s -> bound predicts kd < b + 2 I / h = 0.740
  kp     0: stable for kd up to 0.72, unstable from 0.74 N m s/rad
  kp   100: stable for kd up to 0.62, unstable from 0.64 N m s/rad
"""
