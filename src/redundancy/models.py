"""Where the bundled models are: inside the installed package, or ``models/`` in a checkout."""

from __future__ import annotations

from pathlib import Path

from .errors import UnknownNameError


def _dirs() -> list[Path]:
    here = Path(__file__).resolve().parent
    # A wheel carries models/ as redundancy/models; an editable install reads the checkout's.
    return [here / "models", here.parent.parent / "models"]


def available() -> list[str]:
    """Names of the bundled models (file stems)."""
    names: set[str] = set()
    for d in _dirs():
        if d.is_dir():
            names.update(p.stem for p in d.glob("*.xml"))
    return sorted(names)


def model_path(name: str) -> Path:
    """Path of a bundled model, e.g. ``model_path("arm7")``.

    Raises:
        UnknownNameError: No bundled model has that name (the message lists them).
    """
    for d in _dirs():
        p = d / f"{name}.xml"
        if p.is_file():
            return p
    raise UnknownNameError("model", name, available())


def bundled(name: str) -> Path | None:
    """The bundled model a bare name means (``"panda"``), or None.

    A name means a bundled model only when it is not a file (so a file called ``panda`` in the
    working directory still wins), has no directory part and names one of
    [`available`][redundancy.models.available].
    """
    if not name or Path(name).exists() or Path(name).name != name:
        return None
    stem = name.removesuffix(".xml")
    return model_path(stem) if stem in available() else None


def not_found_hint(name: str) -> str:
    """What to say after "model file not found" for a bare name: the bundled models."""
    if Path(name).name != name:
        return ""
    names = ", ".join(available())
    return f"; bundled models (load by name or rd.model_path(name)): {names}"


#: Arms of example-robot-data (PyPI) with the tool frame each file gives: (file below
#: ``robots/``, tool frame, base body or None). Each is tested as published
#: (``tests/test_robot.py``); ``scripts/survey_robots.py`` prints the table.
EXAMPLE_ARMS: tuple[tuple[str, str, str | None], ...] = (
    ("panda_description/urdf/panda.urdf", "panda_hand", None),
    ("ur_description/urdf/ur3_robot.urdf", "tool0", None),
    ("ur_description/urdf/ur5_robot.urdf", "tool0", None),
    ("ur_description/urdf/ur10_robot.urdf", "tool0", None),
    ("ur_description/urdf/ur5_gripper.urdf", "tool0", None),
    ("kinova_description/robots/kinova.urdf", "j2s6s200_end_effector", None),
    ("xarm_description/urdf/xarm7.urdf", "link_eef", None),
    ("z1_description/urdf/z1.urdf", "link06", None),
    ("z1_description/urdf/z1.urdf", "gripperStator", None),
    ("b1_description/urdf/b1-z1.urdf", "gripperStator", None),
    ("so_arm_description/urdf/so100.urdf", "gripper", None),
    ("so_arm_description/urdf/so101.urdf", "gripper_frame_link", None),
    ("baxter_description/urdf/baxter.urdf", "left_gripper", None),
    ("baxter_description/urdf/baxter.urdf", "right_gripper", None),
    ("pr2_description/urdf/pr2.urdf", "l_gripper_tool_frame", None),
    ("pr2_description/urdf/pr2.urdf", "r_gripper_tool_frame", None),
    ("tiago_description/robots/tiago.urdf", "hand_tool_link", None),
    ("tiago_description/robots/tiago_dual.urdf", "hand_left_tool_link", None),
    ("tiago_description/robots/tiago_dual.urdf", "hand_right_tool_link", None),
    ("tiago_pro_description/robots/tiago_pro.urdf", "arm_left_tool_link", None),
    ("tiago_pro_description/robots/tiago_pro.urdf", "arm_right_tool_link", None),
    ("talos_data/robots/talos_full_v2.urdf", "gripper_left_base_link", None),
    ("talos_data/robots/talos_full_v2.urdf", "gripper_right_base_link", None),
    ("talos_data/robots/talos_full_v2.urdf", "gripper_left_base_link", "torso_2_link"),
    ("romeo_description/urdf/romeo.urdf", "l_gripper", None),
    ("romeo_description/urdf/romeo.urdf", "r_gripper", None),
    ("icub_description/robots/icub.urdf", "l_gripper", None),
    ("icub_description/robots/icub.urdf", "r_gripper", None),
    ("anymal_b_simple_description/robots/anymal-kinova.urdf", "j2s6s200_end_effector", None),
    ("centauro_description/urdf/centauro.urdf", "arm1_8", None),
    ("centauro_description/urdf/centauro.urdf", "arm2_8", None),
    ("g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf", "left_hand_palm_link", None),
    ("g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf", "right_hand_palm_link", None),
    ("alex_description/urdf/alex_nub_hands.urdf", "leftNub", None),
    ("alex_description/urdf/alex_nub_hands.urdf", "rightNub", None),
)


def example_robot_data(path: str) -> Path:
    """Path of a robot file of example-robot-data (PyPI) by its path below ``robots/``.

    Example: ``example_robot_data("ur_description/urdf/ur5_robot.urdf")``.

    The package installs its robots under its own prefix in site-packages; this finds them.

    Raises:
        MissingDependencyError: example-robot-data is not installed.
        UnknownNameError: No such file (the message lists the package's URDF files).
    """
    import importlib.metadata

    from .errors import MissingDependencyError, ParameterError

    if not isinstance(path, str):
        raise ParameterError(
            "path",
            path,
            "a file's path below robots/ (str), e.g. 'ur_description/urdf/ur5_robot.urdf'",
        )

    try:
        files = importlib.metadata.files("example-robot-data") or []
    except importlib.metadata.PackageNotFoundError as err:
        raise MissingDependencyError("example_robot_data", "examples") from err
    urdfs = []
    for f in files:
        text = str(f).replace("\\", "/")
        if "/robots/" not in text:
            continue
        inner = text.split("/robots/", 1)[1]
        if inner == path:
            return Path(str(f.locate()))
        if inner.endswith(".urdf"):
            urdfs.append(inner)
    raise UnknownNameError("example-robot-data file", path, sorted(urdfs))
