"""The geom pairs MuJoCo tests for self-collision, by MuJoCo's own rules."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..checks import describe
from ..errors import ParameterError, UnknownNameError, UnsupportedFeatureError
from ..model.names import display_names
from ..model.robot import bodies_filtered
from .shapes import geom_type_name

if TYPE_CHECKING:
    from ..arm import Arm

Array = NDArray[np.float64]
DistanceEngine = Literal["coal", "mujoco"]
DISTANCE_ENGINES: tuple[DistanceEngine, ...] = ("coal", "mujoco")

#:  Width of the band around a pair's contact threshold inside which the two engines may
#: legitimately disagree on "touching" [m]: MuJoCo's GJK/EPA stops at ``opt.ccd_tolerance`` (1e-6 m
#: by default), coal's at its own tolerances (see `coal_scene`); a pair this close to the threshold
#: is reported as touching by one engine and not the other without either being wrong.
AMBIGUITY_BAND = 1e-6

_G = mujoco.mjtGeom
# Geom types that have no collision function with each other in MuJoCo (mjCOLLISIONFUNC
# holds NULL for plane/hfield against plane/hfield), so MuJoCo never tests such a pair.
_NO_COLLIDER = {int(_G.mjGEOM_PLANE), int(_G.mjGEOM_HFIELD)}


# ==========================================================================================
# The pair set: MuJoCo's rules, read from the compiled model
# ==========================================================================================


@dataclass(frozen=True)
class GeomPair:
    """One geom pair that MuJoCo tests for contact.

    Attributes:
        geom1: Geom id, the smaller of the two.
        geom2: Geom id, the larger.
        name1: Name of ``geom1``; an unnamed geom is named by its body and its index among the
            body's geoms, from 0 (``"link3 geom 2"``,
            [`redundancy.model.names`][redundancy.model.names]).
        name2: Name of ``geom2``, likewise.
        body1: Name of the body carrying ``geom1`` (an unnamed body named likewise).
        body2: Name of the body carrying ``geom2``.
        type1: Geom type of ``geom1`` (``"capsule"``...).
        type2: Geom type of ``geom2``.
        explicit: True for a ``<contact><pair>`` element (which bypasses every filter).
        margin: Distance at which MuJoCo's contact becomes active [m].
        gap: Extra distance over ``margin`` at which MuJoCo already lists the contact [m].
    """

    geom1: int
    geom2: int
    name1: str
    name2: str
    body1: str
    body2: str
    type1: str
    type2: str
    explicit: bool
    margin: float
    gap: float

    @property
    def threshold(self) -> float:
        """MuJoCo lists a contact for the pair when the distance is below this [m]."""
        return self.margin + self.gap

    @property
    def names(self) -> tuple[str, str]:
        """The two geom names, in id order."""
        return (self.name1, self.name2)

    @property
    def label(self) -> str:
        """``"link2 / link4"``: geom names sorted alphabetically, as the lesson prints them."""
        return " / ".join(sorted(self.names))

    @property
    def types(self) -> frozenset[str]:
        """The set of the two geom types."""
        return frozenset((self.type1, self.type2))

    def matches(self, name1: str, name2: str) -> bool:
        """True when the pair is made of the geoms so named, in either order."""
        return {name1, name2} == set(self.names) and (
            name1 != name2 or self.names[0] == self.names[1]
        )

    def __str__(self) -> str:
        return self.label


class NearPair:
    """The contact rule shared by every result that carries a pair and its distance.

    Subclasses are frozen dataclasses declaring ``pair`` and ``distance`` as fields.
    """

    pair: GeomPair
    distance: float

    @property
    def touching(self) -> bool:
        """True when MuJoCo would list a contact: distance below the pair's threshold.

        On a path's first contact, False means a near miss within the checker's tolerance.
        """
        return self.distance < self.pair.threshold


def _margin_gap(model: mujoco.MjModel, g1: int, g2: int, ipair: int) -> tuple[float, float]:
    """Margin and gap of a pair as engine_collision_driver.c's getMargin/getGap compute them."""
    if model.opt.enableflags & mujoco.mjtEnableBit.mjENBL_OVERRIDE:
        # mj_assignMargin: the override replaces every margin (the gap is not overridden).
        margin = float(model.opt.o_margin)
    elif ipair >= 0:
        margin = float(model.pair_margin[ipair])
    else:
        margin = float(model.geom_margin[g1] + model.geom_margin[g2])
    gap = (
        float(model.pair_gap[ipair])
        if ipair >= 0
        else float(model.geom_gap[g1] + model.geom_gap[g2])
    )
    return margin, gap


def _tested_pairs(m: mujoco.MjModel) -> dict[tuple[int, int], int]:
    """The geom pairs that pass MuJoCo's pair rules, each with its ``<pair>`` index.

    Returns:
        (g1, g2) with g1 < g2 -> the index of the ``<contact><pair>`` naming them, or -1 for a
        pair from the body filter, the exclusions and the bitmasks.
    """
    found: dict[tuple[int, int], int] = {}  # (g1, g2) -> ipair (-1: from the filters)
    for k in range(m.npair):
        g1, g2 = sorted((int(m.pair_geom1[k]), int(m.pair_geom2[k])))
        found.setdefault((g1, g2), k)
    # exclude_signature packs the two body ids as (smaller << 16) + larger.
    excluded = {(int(s) >> 16, int(s) & 0xFFFF) for s in m.exclude_signature}
    for g1 in range(m.ngeom):
        for g2 in range(g1 + 1, m.ngeom):
            if (g1, g2) in found:
                continue
            b1, b2 = int(m.geom_bodyid[g1]), int(m.geom_bodyid[g2])
            if bodies_filtered(m, b1, b2):
                continue
            if (min(b1, b2), max(b1, b2)) in excluded:
                continue
            if not (
                m.geom_contype[g1] & m.geom_conaffinity[g2]
                or m.geom_contype[g2] & m.geom_conaffinity[g1]
            ):
                continue
            found[(g1, g2)] = -1
    return found


def collision_pairs(model: mujoco.MjModel | Arm) -> tuple[GeomPair, ...]:
    """The geom pairs MuJoCo's ``mj_collision`` tests for contact, sorted by geom ids.

    Reproduces engine_collision_driver.c from the compiled model (pose-independent rules
    only; the bounding-sphere and bounding-box tests that follow are geometric shortcuts that
    never drop a touching pair):

    * none at all when ``<flag contact="disable"/>`` or ``constraint="disable"``;
    * every ``<contact><pair>``, whatever its geoms' bitmasks, bodies or exclusions;
    * otherwise geoms on bodies that pass the body filter (not welded together, not parent
      and child unless ``filterparent`` is disabled or one side is welded to the world), whose
      bodies are not listed in a ``<contact><exclude>``, and whose bitmasks match:
      ``(contype1 & conaffinity2) | (contype2 & conaffinity1) != 0``. A pair also named in a
      ``<pair>`` element is tested once, with the element's parameters.
    * never plane or height field against plane or height field (MuJoCo has no collider).

    An arm inside a robot: its model carries the whole robot's rules (see
    `reduce_mujoco`), so these are the pairs MuJoCo tests on the
    whole robot with the held joints at rest, less those whose distance the arm cannot change.

    Not modelled: sleeping bodies (``<flag sleep="enable"/>``), which MuJoCo skips pose by
    pose, and flex objects.

    Args:
        model: MuJoCo's compiled model, or an [`Arm`][redundancy.Arm].

    Raises:
        UnsupportedFeatureError: A contact-filter callback is installed
            (``mujoco.set_mjcb_contactfilter``): it replaces the bitmask test with user code
            this function cannot reproduce.
    """
    if not isinstance(model, mujoco.MjModel):
        from ..arm import check_arm

        model = check_arm(model, "model")
    m: mujoco.MjModel = model if isinstance(model, mujoco.MjModel) else model.mj_model
    dsbl = m.opt.disableflags
    if dsbl & (mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT):
        return ()
    if mujoco.get_mjcb_contactfilter() is not None:
        raise UnsupportedFeatureError(
            "contact filter callback",
            "mujoco.set_mjcb_contactfilter",
            "a user callback replaces MuJoCo's bitmask test; the pair set cannot be reproduced",
        )
    found = _tested_pairs(m)
    geoms = display_names(m, mujoco.mjtObj.mjOBJ_GEOM)
    bodies = display_names(m, mujoco.mjtObj.mjOBJ_BODY)
    pairs = []
    for (g1, g2), ipair in sorted(found.items()):
        if int(m.geom_type[g1]) in _NO_COLLIDER and int(m.geom_type[g2]) in _NO_COLLIDER:
            continue
        margin, gap = _margin_gap(m, g1, g2, ipair)
        pairs.append(
            GeomPair(
                geom1=g1,
                geom2=g2,
                name1=geoms[g1],
                name2=geoms[g2],
                body1=bodies[int(m.geom_bodyid[g1])],
                body2=bodies[int(m.geom_bodyid[g2])],
                type1=geom_type_name(m, g1),
                type2=geom_type_name(m, g2),
                explicit=ipair >= 0,
                margin=margin,
                gap=gap,
            )
        )
    return tuple(pairs)


def find_pair(pairs: Sequence[GeomPair], name1: str, name2: str) -> GeomPair:
    """The pair of the geoms so named (either order).

    Raises:
        UnknownNameError: No such pair in ``pairs`` (the message lists the pairs).
        ParameterError: ``pairs`` not a sequence of GeomPair, a name not a string.
    """
    if not isinstance(pairs, Sequence) or not all(isinstance(p, GeomPair) for p in pairs):
        raise ParameterError(
            "pairs", pairs, "a sequence of GeomPair (collision_pairs(arm))", describe(pairs)
        )
    for name, value in (("name1", name1), ("name2", name2)):
        if not isinstance(value, str):
            raise ParameterError(name, value, "a geom name (str)", describe(value))
    for p in pairs:
        if p.matches(name1, name2):
            return p
    raise UnknownNameError("geom pair", f"{name1} / {name2}", [p.label for p in pairs])
