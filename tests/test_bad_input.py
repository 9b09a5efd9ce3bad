"""Malformed and hostile input, table-driven: the library's own exception, a message naming
the cause, and no engine output on the terminal.

tests/test_errors.py holds the first 27 cases (unknown names, pose shapes and values, not XML,
truncated XML, an unknown attribute, a NaN size, a negative mass, no joints, ball and free
joints, several joints in one body, an unnamed joint, tendons, equality constraints,
``<frame>``, several kinematic trees, ``<include>``); this table adds the rest. The fuzz of
arm7.xml (its text and its structure) is in tests/test_fuzz.py, where each mutant loads in a
guarded worker process so that an engine abort cannot end the test run.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

import redundancy as rd

from .fullmodel import largest_difference_to_full_model
from .models import chain

JOINTS = "['q1', 'q2', 'q3', 'q4', 'q5', 'q6', 'q7']"
ARM7_TEXT = rd.model_path("arm7").read_text()
#: Text an engine prints when it complains (MuJoCo's warnings, C++ or Python tracebacks).
ENGINE_NOISE = re.compile(r"WARNING|Error|error:|Traceback|terminate|Segmentation|Assertion")


@dataclass(frozen=True)
class Case:
    """One bad input: what to call, the exception it must raise and its message (a regex)."""

    call: Callable[[], object]
    error: type[Exception]
    message: str
    quiet: bool = True  # nothing may be printed on stdout or stderr


def _load(xml: object, frame: str = "tip", strict: bool = True) -> Callable[[], object]:
    return lambda: rd.load_string(xml, frame=frame, strict=strict)  # type: ignore[arg-type]


def _load_site(xml: str, site: object) -> Callable[[], object]:
    """``load_string`` with the deprecated ``site=``: still checked, and it warns."""

    def call() -> object:
        with pytest.warns(DeprecationWarning):
            return rd.load_string(xml, site=site)  # type: ignore[arg-type]

    return call


def _load_file(tmp: str, name: str, text: str, frame: str = "tip") -> Callable[[], object]:
    def call() -> object:
        path = Path(tmp) / name
        path.write_text(text)
        return rd.load(path, frame=frame)

    return call


def _l2(attrs: str) -> str:
    """chain() with extra attributes on body l2."""
    return chain().replace(
        '<body name="l2" pos="0 0 0.3">', f'<body name="l2" pos="0 0 0.3" {attrs}>'
    )


UF = "unsupported feature: "
MJ = r"MuJoCo could not compile the model: "
MESH = '<asset><mesh name="m" file="/nonexistent/m.stl"/></asset>'
CUBE = (
    '<asset><mesh name="cube" vertex="0 0 0 .1 0 0 0 .1 0 .1 .1 0 0 0 .1 .1 0 .1 0 .1 .1 '
    '.1 .1 .1"/></asset>'
)
RADIAN = '<mujoco><compiler angle="radian"/>'


def cases(tmp: str, arm: rd.Arm | None = None) -> dict[str, Case]:
    """The table; ``tmp`` is a scratch directory for file-based cases, ``arm`` the arm the
    pose cases call (None when only the names are wanted)."""
    return {
        # -- not an MJCF model ----------------------------------------------------------------
        "empty text": Case(
            _load(""), rd.ModelError, r"^not well-formed XML: no element found: line 1, column 0$"
        ),
        "bytes, decoded as XML says": Case(
            _load(b"<mujoco/>"),
            rd.UnknownNameError,
            r"^unknown site or body 'tip'; valid site or body names: \[none\]$",
        ),
        "None, not str": Case(
            _load(None), rd.ModelError, r"^model text must be a str or bytes, got NoneType$"
        ),
        "URDF without joints": Case(
            _load('<robot name="r"><link name="a"/></robot>'),
            rd.UnsupportedFeatureError,
            "^"
            + re.escape(
                UF + "no joints (<string>): an arm needs at least one revolute, continuous or "
                "prismatic joint"
            ),
        ),
        "arm7 cut in half": Case(
            _load(ARM7_TEXT[: len(ARM7_TEXT) // 2], frame="ee"),
            rd.ModelError,
            r"^not well-formed XML: [a-z ]+: line \d+, column \d+$",
        ),
        "mismatched tag": Case(
            _load(chain().replace("</worldbody>", "</world>")),
            rd.ModelError,
            r"^not well-formed XML: mismatched tag: line 14, column 4$",
        ),
        "unknown element": Case(
            _load(chain(body_extra="<bogus/>")),
            rd.ModelError,
            "^" + MJ + r"XML Error: Schema violation: unrecognized element\n"
            "Element 'bogus'",
        ),
        "unknown joint type": Case(
            _load(chain(joints='<joint name="a" type="hinj"/>')),
            rd.ModelError,
            "^" + MJ + r"XML Error: invalid keyword: 'hinj'",
        ),
        # -- files ------------------------------------------------------------------------------
        "a directory": Case(
            lambda: rd.load(tmp),
            rd.ModelError,
            "^" + re.escape(f"model path is a directory, not a file: {tmp!r}") + "$",
        ),
        "missing mesh file": Case(
            _load(
                chain(body_extra='<geom type="mesh" mesh="m"/>').replace(
                    "<mujoco>", "<mujoco>" + MESH
                )
            ),
            rd.ModelError,
            "^" + MJ + re.escape("Error: Error opening file '/nonexistent/m.stl'"),
        ),
        "include in a file": Case(  # MuJoCo follows it first, and names what is missing
            _load_file(
                tmp, "inc.xml", chain().replace("<mujoco>", '<mujoco><include file="x.xml"/>')
            ),
            rd.ModelError,
            "^" + MJ + ".*x\\.xml",
        ),
        "arm7 without its site": Case(
            _load_file(tmp, "nosite.xml", ARM7_TEXT, frame="flange"),
            rd.UnknownNameError,
            r"^unknown site or body 'flange'; valid site or body names: \['ee', 'link1', 'link2', "
            r"'link3', 'link4', 'link5', 'link6', 'link7'\]$",
        ),
        # -- NaN, inf and impossible values -----------------------------------------------------
        "inf in a body pos": Case(
            _load(chain().replace('pos="0 0 0.1"', 'pos="0 0 inf"')),
            rd.ModelError,
            "^"
            + re.escape(
                "non-finite number in the model: <body name='l1'> "
                "pos='0 0 inf'; every number must be finite"
            )
            + "$",
        ),
        "NaN in a joint axis": Case(
            _load(chain(joints='<joint name="a" axis="0 nan 0"/>')),
            rd.ModelError,
            "^"
            + re.escape(
                "non-finite number in the model: <joint name='a'> "
                "axis='0 nan 0'; every number must be finite"
            )
            + "$",
        ),
        "inf mass": Case(
            _load(chain(body_extra='<inertial pos="0 0 0" mass="inf" diaginertia="1 1 1"/>')),
            rd.ModelError,
            "^"
            + re.escape(
                "non-finite number in the model: <inertial> mass='inf'; every number must be finite"
            )
            + "$",
        ),
        "-inf gravity": Case(
            _load(chain().replace("<mujoco>", '<mujoco><option gravity="0 0 -inf"/>')),
            rd.ModelError,
            "^"
            + re.escape(
                "non-finite number in the model: <option> gravity='0 0 -inf'; "
                "every number must be finite"
            )
            + "$",
        ),
        "zero mass": Case(
            _load(chain(body_extra='<inertial pos="0 0 0" mass="0" diaginertia="1 1 1"/>')),
            rd.ModelError,
            "^" + MJ + "Error: mass and inertia of moving bodies must be larger than mjMINVAL"
            r"\nElement name 'l2'",
        ),
        "zero density": Case(
            _load(chain().replace('size="0.04"/>', 'size="0.04" density="0"/>')),
            rd.ModelError,
            "^" + MJ + "Error: mass and inertia of moving bodies must be larger than "
            r"mjMINVAL\nElement name 'l1'",
        ),
        "negative geom mass": Case(
            _load(chain(body_extra='<geom size="0.02" mass="-1"/>')),
            rd.ModelError,
            "^" + MJ + "Error: mass, inertia or density are negative in geom",
        ),
        "negative armature": Case(
            _load(chain(joints='<joint name="a" axis="0 1 0" armature="-1"/>')),
            rd.ModelError,
            "^" + re.escape("joint 'a' has negative armature -1 [kg m^2]; it must be >= 0") + "$",
        ),
        "negative damping": Case(
            _load(chain(joints='<joint name="a" axis="0 1 0" damping="-0.5"/>')),
            rd.ModelError,
            "^"
            + re.escape("joint 'a' has negative damping -0.5 [N m s/rad]; it must be >= 0")
            + "$",
        ),
        "inverted range": Case(
            _load(chain(joints='<joint name="a" type="slide" axis="0 0 1" range="0.2 -0.2"/>')),
            rd.ModelError,
            "^"
            + re.escape("joint 'a' has range [0.2, -0.2]: the lower limit is above the upper limit")
            + "$",
        ),
        "zero joint axis": Case(
            _load(chain(joints='<joint name="a" axis="0 0 0"/>')),
            rd.ModelError,
            "^" + MJ + r"Error: axis too small in joint\nElement name 'a'",
        ),
        "zero quaternion": Case(
            _load(_l2('quat="0 0 0 0"')),
            rd.ModelError,
            "^" + MJ + "XML Error: zero quaternion is not allowed",
        ),
        "two orientations": Case(
            _load(_l2('quat="1 0 0 0" euler="0 0 1"')),
            rd.ModelError,
            "^" + MJ + "XML Error: multiple orientation specifiers are not allowed",
        ),
        "range without limited": Case(
            _load(
                chain(joints='<joint name="a" axis="0 1 0" range="-1 1"/>').replace(
                    "<mujoco>", '<mujoco><compiler autolimits="false"/>'
                )
            ),
            rd.ModelError,
            "^" + MJ + "Error: joint has `range` but not `limited`",
        ),
        # -- names and keyframes ------------------------------------------------------------------
        "keyframe of the wrong length": Case(
            _load(chain(extra='<keyframe><key name="k" qpos="0 0 0"/></keyframe>')),
            rd.ModelError,
            "^" + MJ + "Error: keyframe 'k': invalid qpos size, expected 2, got 3",
        ),
        "repeated joint name": Case(
            _load(chain(joints='<joint name="b" axis="0 1 0"/>')),
            rd.ModelError,
            "^" + MJ + "XML Error: Error: repeated name 'b' in joint",
        ),
        "actuator on a missing joint": Case(
            _load(chain(extra='<actuator><motor joint="zz"/></actuator>')),
            rd.ModelError,
            "^" + MJ + "Error: unknown transmission target 'zz' for actuator id = 0",
        ),
        "site on the world body": Case(
            _load(chain().replace("<worldbody>", '<worldbody><site name="w"/>'), frame="w"),
            rd.UnsupportedFeatureError,
            "^"
            + re.escape(
                UF + "no joints (the chain from 'world' to 'w'): an arm needs at least one hinge "
                "or slide joint on its chain"
            )
            + "$",
        ),
        "site not a name": Case(
            _load_site(chain(), 3),
            rd.ModelError,
            r"^site must be a name \(str\) or None, got int$",
        ),
        # -- features the engines read differently or not at all -----------------------------------
        "shell inertia": Case(
            _load(chain(body_extra='<geom size="0.05" shellinertia="true"/>'), strict=False),
            rd.UnsupportedFeatureError,
            "^"
            + re.escape(
                UF + "shell inertia (<geom shellinertia='true'>): Pinocchio's MJCF parser "
                "cannot compute it; use a solid geom or an explicit <inertial>"
            )
            + "$",
        ),
        "body placed at 1e308 m": Case(
            _load(
                _l2('pos="0 0 1e308"').replace('<body name="l2" pos="0 0 0.3" ', '<body name="l2" ')
            ),
            rd.ModelError,
            "^"
            + re.escape(
                "implausible value in the compiled model: body_pos of body 'l2' is "
                "[0.0, 0.0, 1e+308]; the library handles magnitudes up to 1e+10 (SI units): "
                "beyond, the engines' products overflow"
            )
            + "$",
        ),
        "joint named universe": Case(
            _load(chain(joints='<joint name="universe" axis="0 1 0"/>')),
            rd.UnsupportedFeatureError,
            "^"
            + re.escape(
                UF + "joint named 'universe' (joint 'universe'): Pinocchio reserves the name "
                "'universe' for its world joint (its parser aborts on it); rename the joint"
            )
            + "$",
        ),
        "sdf geom": Case(
            _load(
                chain(body_extra='<geom name="blob" type="sdf" mesh="cube"/>').replace(
                    "<mujoco>", "<mujoco>" + CUBE
                )
            ),
            rd.ModelError,
            r"sdf|SDF",
        ),
        "free joint below the root": Case(
            _load(
                chain(joints='<joint name="a" axis="0 1 0"/>').replace(
                    '<joint name="b" axis="0 1 0"/>', '<freejoint name="b"/>'
                )
            ),
            rd.ModelError,
            "^" + MJ + "Error: free joint can only be used on top level",
        ),
        # -- poses and other arguments ---------------------------------------------------------
        "complex pose": Case(
            lambda: arm.jacobian(np.full(7, 0.1 + 1j)),
            rd.PoseError,
            r"^pose must be real, got complex values$",
        ),
        "pose as text": Case(
            lambda: arm.jacobian("0 0 0 0 0 0 0"),
            rd.PoseError,
            r"^pose must be numeric, got str: could not convert string to float",
        ),
        "pose None": Case(
            lambda: arm.gravity(None),
            rd.PoseError,
            "^" + re.escape(f"pose must have shape (7,) for joints {JOINTS}, got shape ()") + "$",
        ),
        "pose dict": Case(
            lambda: arm.mass_matrix({}), rd.PoseError, r"^pose must be numeric, got dict"
        ),
        "ragged pose": Case(
            lambda: arm.jacobian([[0, 0, 0], [0, 0, 0, 0]]),
            rd.PoseError,
            r"^pose must be numeric, got list: setting an array element with a sequence",
        ),
        "column pose": Case(
            lambda: arm.jacobian(np.zeros((7, 1))),
            rd.PoseError,
            "^"
            + re.escape(f"pose must have shape (7,) for joints {JOINTS}, got shape (7, 1)")
            + "$",
        ),
        "empty pose": Case(
            lambda: arm.site_pose([]),
            rd.PoseError,
            "^" + re.escape(f"pose must have shape (7,) for joints {JOINTS}, got shape (0,)") + "$",
        ),
        "slide out of range": Case(
            lambda: arm.pose([0, 0, 0.2, 0, 0, 0, 0], check_range=True),
            rd.OutOfRangeError,
            r"^joint 'q3' = 0.2 is outside its range \[-0.1, 0.1\]$",
        ),
        "NaN pose in crosscheck": Case(
            lambda: rd.crosscheck(arm, np.full((2, 7), np.nan)),
            rd.PoseError,
            r"^pose 0 has non-finite values: q1=nan, q2=nan",
        ),
        "inf pose in compare_models": Case(
            lambda: rd.compare_models(arm, np.full(7, np.inf)),
            rd.PoseError,
            r"^pose has non-finite values: q1=inf",
        ),
        "unknown engine": Case(
            lambda: arm.jacobian(np.zeros(7), engine="bullet"),  # type: ignore[arg-type]
            rd.UnknownNameError,
            r"^unknown engine 'bullet'; valid engine names: \['mujoco', 'pinocchio', 'drake'\]$",
        ),
    }


NAMES = list(cases("/tmp"))


@pytest.mark.parametrize("name", NAMES)
def test_bad_input(
    name: str, tmp_path: Path, capfd: pytest.CaptureFixture[str], skew7: rd.Arm
) -> None:
    case = cases(str(tmp_path), skew7)[name]
    capfd.readouterr()
    with pytest.raises(case.error) as exc:
        case.call()
    assert isinstance(exc.value, rd.RedundancyError)
    assert re.search(case.message, str(exc.value)), str(exc.value)
    out, err = capfd.readouterr()
    if case.quiet:
        assert not ENGINE_NOISE.search(out + err), out + err


def test_table_size() -> None:
    assert len(NAMES) >= 40


def test_attach_is_given_to_pinocchio_as_mujoco_resolved_it(tmp_path: Path) -> None:
    """Pinocchio's MJCF parser does not expand <attach> (a 3 kg block attached to
    the arm was in MuJoCo's M only: M11 0.456 vs 0.105); Pinocchio gets MuJoCo's model."""
    (tmp_path / "block.xml").write_text(
        '<mujoco><worldbody><body name="blk" pos="0 0 0.3">'
        '<geom type="box" size="0.05 0.05 0.05" mass="3"/></body></worldbody></mujoco>'
    )
    arm = tmp_path / "arm.xml"
    arm.write_text(
        chain(body_extra='<attach model="block" body="blk" prefix="b_"/>').replace(
            "<mujoco>", '<mujoco><asset><model name="block" file="block.xml"/></asset>'
        )
    )
    loaded = rd.load(arm, frame="tip")
    assert loaded.mj_model.nbody == 4  # MuJoCo expands it
    (note,) = [b for b in loaded.bridges if b.quantity == "whole model"]
    assert note.source.endswith("because of <attach> (Pinocchio's parser does not expand it)")
    q = np.array([0.3, -0.5])
    M = loaded.mass_matrix(q, engine="pinocchio")
    np.testing.assert_allclose(M, loaded.mass_matrix(q), rtol=0, atol=1e-12)
    assert largest_difference_to_full_model(loaded, q) < 1e-12


READ_DIFFERENTLY = {
    "frame around the arm": (
        chain()
        .replace("<worldbody>", '<worldbody><frame pos="0 0 1" euler="10 0 20">')
        .replace("</worldbody>", "</frame></worldbody>"),
        "<frame> (Pinocchio's parser drops its contents)",
    ),
    "replicate": (
        chain(body_extra='<replicate count="2" offset="0 0 0.1"><geom size="0.01"/></replicate>'),
        "<replicate> (Pinocchio's parser does not expand it)",
    ),
    "compiler after worldbody": (
        chain().replace("</worldbody>", '</worldbody><compiler angle="radian"/>'),
        "<compiler> after <worldbody> (Pinocchio's parser applies it only to what follows)",
    ),
    "default after worldbody": (
        chain().replace("</worldbody>", '</worldbody><default><joint damping="1"/></default>'),
        "<default> after <worldbody> (Pinocchio's parser applies it only to what follows)",
    ),
    "extrinsic eulerseq": (
        chain()
        .replace("<mujoco>", '<mujoco><compiler eulerseq="ZYX"/>')
        .replace('<body name="l2" pos="0 0 0.3"', '<body name="l2" pos="0 0 0.3" euler="5 10 20"'),
        "<compiler eulerseq='ZYX'> (Pinocchio's parser reads it as intrinsic)",
    ),
    "non-unit axisangle": (
        _l2('axisangle="0 0 2 30"'),
        "<body name='l2' axisangle='0 0 2 30'> (Pinocchio's parser does not normalise the axis)",
    ),
}


@pytest.mark.parametrize("name", list(READ_DIFFERENTLY))
def test_read_differently_is_served(name: str) -> None:
    """Valid MJCF that Pinocchio's parser reads differently (once refused): served
    with MuJoCo's compiled model given to Pinocchio, the cause named in ``arm.bridges``."""
    xml, cause = READ_DIFFERENTLY[name]
    arm = rd.load_string(xml, frame="tip")
    (note,) = [b for b in arm.bridges if b.quantity == "whole model"]
    assert note.source.endswith(f"because of {cause}")
    for q in ([0.3, -0.5], [1.2, 0.4]):
        assert largest_difference_to_full_model(arm, np.array(q)) < 1e-12


def test_jointinparent_actuator_reads_as_joint() -> None:
    """MuJoCo applies +-80 N m through ``jointinparent`` on a hinge; it was
    ignored (effort unlimited, ``actuated`` False)."""
    from redundancy.model.actuators import effort_range

    extra = (
        '<actuator><motor jointinparent="a" ctrlrange="-80 80"/>'
        '<motor joint="b" ctrlrange="-1 1"/></actuator>'
    )
    arm = rd.load_string(
        chain(extra=extra).replace("<mujoco>", '<mujoco><compiler autolimits="true"/>'),
        frame="tip",
    )
    effort = effort_range(arm.mj_model)
    np.testing.assert_array_equal(effort.lower, [-80.0, -1.0])
    np.testing.assert_array_equal(effort.upper, [80.0, 1.0])
    assert effort.actuated.tolist() == [True, True]
    # The audit: no "no actuator" finding, the JSON says actuated, the effort MuJoCo applies.
    from redundancy.reports.audit import audit

    report = audit(arm, n_poses=20)
    assert not any("no actuator" in f["message"] for f in report.to_dict()["findings"])
    joint_a = report.to_dict()["joints"][0]
    assert (joint_a["actuated"], joint_a["effort_lower"], joint_a["effort_upper"]) == (
        True,
        -80.0,
        80.0,
    )


@pytest.mark.parametrize(
    ("actuator", "expected"),
    [
        (
            '<motor site="tip" gear="1 0 0 0 0 0"/>',
            "site transmission (actuator 'push')",
        ),
        (
            '<adhesion body="l2" ctrlrange="0 1"/>',
            "body (adhesion) transmission (actuator 'push')",
        ),
    ],
)
def test_site_and_body_transmissions_on_the_arm_are_refused(actuator: str, expected: str) -> None:
    """Read neither as effort nor as armature; refused, naming the actuator."""
    named = actuator.replace(" ", ' name="push" ', 1)
    message = (
        UF + expected + ": it drives the arm's joints through pose-dependent moment arms; the "
        "library reads actuators with a joint transmission only (joint, jointinparent)"
    )
    with pytest.raises(rd.UnsupportedFeatureError, match="^" + re.escape(message) + "$"):
        rd.load_string(chain(extra=f"<actuator>{named}</actuator>"), frame="tip")


@pytest.mark.parametrize("kind", ["site", "body"])
def test_check_transmissions_refuses_site_and_body_transmissions(kind: str) -> None:
    import mujoco

    from redundancy.model.actuators import check_transmissions

    actuator = (
        '<motor name="push" site="tip" gear="1 0 0 0 0 0"/>'
        if kind == "site"
        else '<adhesion name="push" body="l2" ctrlrange="0 1"/>'
    )
    model = mujoco.MjModel.from_xml_string(chain(extra=f"<actuator>{actuator}</actuator>"))
    what = "site transmission" if kind == "site" else "body (adhesion) transmission"
    message = (
        UF + f"{what} (actuator 'push'): it drives the arm's joints through pose-dependent "
        "moment arms; the library reads actuators with a joint transmission only (joint, "
        "jointinparent)"
    )
    with pytest.raises(rd.UnsupportedFeatureError, match="^" + re.escape(message) + "$"):
        check_transmissions(model)


def test_site_transmission_off_the_arm_is_allowed() -> None:
    world_site = chain(extra='<actuator><motor site="w" gear="1 0 0 0 0 0"/></actuator>')
    xml = world_site.replace("<worldbody>", '<worldbody><site name="w" pos="1 0 0"/>')
    assert rd.load_string(xml, frame="tip", strict=False).nq == 2


def test_tendon_transmission_is_refused_with_the_tendon() -> None:
    tendon = (
        '<tendon><fixed name="t"><joint joint="a" coef="1"/></fixed></tendon>'
        '<actuator><motor tendon="t"/></actuator>'
    )
    with pytest.raises(
        rd.UnsupportedFeatureError,
        match=r"^unsupported feature: tendon on an arm joint \(tendon 't' \(arm joint 'a'\)\)",
    ):
        rd.load_string(chain(extra=tendon), frame="tip")


def test_unnamed_keyframe_does_not_overwrite_a_named_one() -> None:
    """An unnamed key 1 was called key1 and replaced the real key1 (nkey 2, 1 kept)."""
    keys = '<keyframe><key name="key1" qpos="0.1 0.2"/><key qpos="0.3 0.4"/></keyframe>'
    arm = rd.load_string(chain(extra=keys), frame="tip")
    assert arm.mj_model.nkey == 2
    assert list(arm.keyframes) == ["key1", "key1_"]
    np.testing.assert_array_equal(arm.keyframe("key1"), [0.1, 0.2])
    np.testing.assert_array_equal(arm.keyframe("key1_"), [0.3, 0.4])
