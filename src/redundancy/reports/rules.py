"""The audit's rules, each declared once: a stable id, a severity, a kind and one sentence.

A finding or note names its rule by id (`RULES`); the guide's audit page lists the catalogue,
and the CI formats (SARIF's rules, JUnit's test cases) are built from it. An id never changes
meaning: a rule that is replaced gets a new id.
"""

from __future__ import annotations

from dataclasses import dataclass

from .findings import Severity


@dataclass(frozen=True)
class Rule:
    """One check of the audit.

    Attributes:
        id: Stable, kebab-case id (``keyframe-unheld``): what baselines and CI formats key on.
        severity: ``error`` (the numbers are wrong or unsafe), ``warning`` (likely wrong, worth
            a look) or ``note`` (what the audit could not judge, or assumed).
        kind: The category the text report prints in brackets (``gravity``, ``format``...).
        summary: One sentence: what the rule checks.
    """

    id: str
    severity: Severity
    kind: str
    summary: str


_CATALOGUE = (
    # -- the model's inertias -------------------------------------------------------------------
    Rule("published-inertia", "error", "published inertia",
         "A moving link's published mass or inertia is one MuJoCo rejects (not positive "
         "definite, or breaking the triangle inequality)."),
    Rule("mass-not-positive", "error", "published inertia",
         "A moving link has an <inertial> of mass 0 or below: no body moves without mass."),
    Rule("inertia-unit", "error", "published inertia",
         "A moving link's inertia is 300x or more its collision geometry's at its mass."),
    Rule("gyration-radius", "error", "published inertia",
         "A moving link's radius of gyration sqrt(I/m) is over 10x the link's size."),
    Rule("com-outside-link", "error", "published inertia",
         "A moving link's centre of mass is outside its geometry by more than its size + 10 cm."),
    Rule("mass-matrix-ill-conditioned", "warning", "inertia",
         "cond(M) above 1e9: whatever is solved with M carries a rounding above 1e-7."),
    Rule("inertia-missing", "note", "inertia",
         "A moving link has no inertial data: the sections that need M or gravity are skipped."),
    Rule("meshes-missing", "note", "meshes",
         "The file names meshes found nowhere: the self-collision sweep is skipped."),
    Rule("collision-engines-differ", "note", "meshes",
         "The engines place the collision geoms apart (a lenient load): the sweep is skipped."),
    # -- what the file's format cannot express ---------------------------------------------------
    Rule("urdf-no-armature", "note", "format",
         "URDF cannot express armature: the mass matrix has no rotor inertia."),
    Rule("urdf-no-actuators", "note", "format",
         "URDF cannot express actuators: each joint's effort limit is the torque limit."),
    Rule("urdf-no-timestep", "note", "format",
         "URDF cannot express the timestep or the integrator: MuJoCo's defaults are used."),
    # -- joints and simulation -------------------------------------------------------------------
    Rule("armature-zero", "note", "armature",
         "A joint has zero armature: a geared joint's reflected rotor inertia is missing."),
    Rule("armature-uniform", "note", "armature",
         "Every joint has the same armature, where reflected inertia differs joint by joint."),
    Rule("timestep-unstable", "error", "timestep",
         "The timestep is above a joint's stable bound for explicit damping."),
    Rule("timestep-default-unstable", "note", "timestep",
         "MuJoCo's default timestep (the file sets none) is above a joint's stable bound."),
    Rule("timestep-not-positive", "error", "timestep",
         "The timestep is zero or negative: MuJoCo cannot step the model."),
    Rule("gravity-disabled", "warning", "simulation",
         "Gravity is disabled: the motors are never checked against the arm's weight."),
    Rule("reference-out-of-range", "note", "joint",
         "The reference pose (qpos0), where MuJoCo starts, puts a joint outside its range."),
    Rule("effort-limit-zero", "error", "joint",
         "A moving joint's effort limit is 0: its motor gives no torque."),
    Rule("velocity-limit-zero", "error", "joint",
         "A moving joint's velocity limit is 0: it may not move."),
    # -- keyframes --------------------------------------------------------------------------------
    Rule("keyframe-out-of-range", "error", "keyframe",
         "A keyframe puts a joint outside its range."),
    Rule("keyframe-loop-open", "error", "keyframe",
         "A keyframe puts a coupled arm where its loop cannot close."),
    Rule("keyframe-singular", "warning", "keyframe",
         "A keyframe is a singular pose of the tool (sigma_min below 1e-3)."),
    Rule("keyframe-self-contact", "error", "keyframe",
         "A keyframe puts links of the arm in contact with each other."),
    Rule("keyframe-unheld", "error", "keyframe",
         "A joint's actuators cannot hold a keyframe against gravity."),
    # -- gravity against the motors ---------------------------------------------------------------
    Rule("joint-unactuated-loaded", "error", "gravity",
         "Gravity loads a joint that has no actuator: nothing holds it."),
    Rule("joint-tendon-actuated", "note", "gravity",
         "A coupled arm's joints are driven only through a tendon actuator: not judged."),
    Rule("gravity-over-limit", "error", "gravity",
         "Gravity needs more torque at a joint than its actuators (or URDF effort) give."),
    # -- the engines ------------------------------------------------------------------------------
    Rule("engines-contacts-differ", "error", "engines",
         "The distance engine's touching pairs differ from MuJoCo's contacts."),
    Rule("engines-disagree", "error", "engines",
         "The engines' numbers for a quantity differ by more than its tolerance."),
    Rule("engines-models-differ", "error", "engines",
         "The engines read different arms from the file (a joint, body or value differs)."),
    # -- self-collision ---------------------------------------------------------------------------
    Rule("pair-always-touching", "note", "collision",
         "Two links touch at (nearly) every pose: most likely an exclusion the file lacks."),
    Rule("srdf-beside", "note", "collision",
         "The SRDF of the URDF's name beside it is applied: its pairs are never tested."),
)  # fmt: skip

#: Every rule of the audit by id, in the order the guide lists them.
RULES: dict[str, Rule] = {r.id: r for r in _CATALOGUE}


def rule(rule_id: str) -> Rule:
    """The rule of an id.

    Args:
        rule_id: A key of `RULES`.

    Raises:
        KeyError: For an id the catalogue does not declare (a programming error: every
            finding's rule must be declared).
    """
    return RULES[rule_id]
