"""From a model file to an [`Arm`][redundancy.Arm]: loading, support rules, bridges, equivalence.

* [`loading`][redundancy.model.loading]: read a file or text into both engines and build the Arm;
* `support`: what is refused, and why (the engines would disagree);
* `bridges`: what is copied from MuJoCo into Pinocchio, and reported;
* `actuators`: what actuators add to each joint (limits, armature, damping);
* [`equivalence`][redundancy.model.equivalence]: the two compiled models compared side by side.
"""
