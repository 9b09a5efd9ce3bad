"""From a model file to an [`Arm`][redundancy.Arm]: loading, support rules, bridges, equivalence.

* `loading`: read a file or text into both engines and build the Arm (each format's path in
  `mjcf_loading` and `urdf_loading`, the Arm built in `assembly`);
* `robot`: the arm inside a robot, the rest of it held (`selection`, `couplings`,
  `contact_rules`, `reduced_pinocchio`);
* `urdf`: URDF in both engines (`urdf_tree`, `urdf_inertia`, `urdf_pinocchio`);
* `support`: what is refused, and why (the engines would disagree);
* `bridges`: what is copied from MuJoCo into Pinocchio, and reported;
* `resolved`: MuJoCo's compiled model as plain MJCF, for Pinocchio where
  its parser reads the file differently;
* `actuators`: what actuators add to each joint (limits, armature, damping);
* `equivalence`: the two compiled models compared side by side.
"""
