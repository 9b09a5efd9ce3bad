"""From a model file to an [`Arm`][redundancy.Arm]: loading, support rules, bridges, equivalence.

* :mod:`~redundancy.model.loading`: read a file or text into both engines and build the Arm;
* :mod:`~redundancy.model.support`: what is refused, and why (the engines would disagree);
* :mod:`~redundancy.model.bridges`: what is copied from MuJoCo into Pinocchio, and reported;
* :mod:`~redundancy.model.resolved`: MuJoCo's compiled model as plain MJCF, for Pinocchio where
  its parser reads the file differently;
* :mod:`~redundancy.model.actuators`: what actuators add to each joint (limits, armature, damping);
* :mod:`~redundancy.model.equivalence`: the two compiled models compared side by side.
"""
