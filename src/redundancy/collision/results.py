"""What a collision sweep reports: per pair, per keyframe, and the whole sample's table."""

from __future__ import annotations

from dataclasses import dataclass, field

from ..display import Report, Table, plural, table
from .checker import PairDistance
from .pairs import Array, GeomPair, find_pair


@dataclass(frozen=True)
class PairStatistics:
    """One pair over a sample of poses.

    Attributes:
        pair: The pair.
        poses: Poses in which MuJoCo lists at least one contact for the pair.
        contacts: Contacts MuJoCo lists for the pair, summed over the poses (a capsule pair
            can give two per pose, a box pair up to eight).
        closest: Smallest signed distance over the poses [m] (``nan`` without distances).
        closest_pose: Index of that pose in the sample (-1 without distances).
    """

    pair: GeomPair
    poses: int
    contacts: int
    closest: float
    closest_pose: int


@dataclass(frozen=True)
class KeyframeClearance:
    """Self-collision at one keyframe.

    Attributes:
        keyframe: Keyframe name.
        q: Its pose [rad or m].
        contacts: Number of contacts MuJoCo lists there.
        closest: The pair with the smallest clearance, with its distance (None: no pairs).
        moves_held: Held joints the keyframe puts elsewhere than the arm holds them -> the
            keyframe's value [rad or m]; the clearance is measured there
            (`at_keyframe`).
    """

    keyframe: str
    q: Array
    contacts: int
    closest: PairDistance | None
    moves_held: dict[str, float | tuple[float, ...]] = field(default_factory=dict)


class ContactShare:
    """``share_with_contact`` of a sweep's counts ``poses_with_contact`` and ``n_poses``."""

    poses_with_contact: int
    n_poses: int

    @property
    def share_with_contact(self) -> float:
        """``poses_with_contact`` over ``n_poses``, in [0, 1] (0 without poses)."""
        return self.poses_with_contact / self.n_poses if self.n_poses else 0.0


@dataclass(frozen=True, repr=False)
class CollisionStatistics(ContactShare, Report):
    """Self-collision over random poses, as the lesson's table (4), labelled honestly.

    ``print(stats)`` prints [`lines`][redundancy.collision.CollisionStatistics.lines]; a notebook
    shows the pairs as an HTML table.

    Attributes:
        n_poses: Number of poses drawn.
        seed: Seed of ``np.random.default_rng``.
        distance_engine: Engine of the distances (``None``: contacts only).
        poses_with_contact: Poses in which MuJoCo lists at least one contact.
        pairs: Per pair, in pair-set order.
        keyframes: Clearance at each keyframe.
        disagreements: Poses where the distance engine's touching pairs differ from MuJoCo's contact
            pairs, not counting pairs within `AMBIGUITY_BAND` of their threshold (0 expected; -1
            without distances).
        seconds: Wall time of the sweep [s].
        share_with_contact: Fraction of the poses with at least one contact, in [0, 1].
    """

    n_poses: int
    seed: int | None
    distance_engine: str | None
    poses_with_contact: int
    pairs: tuple[PairStatistics, ...]
    keyframes: tuple[KeyframeClearance, ...]
    disagreements: int
    seconds: float

    def of(self, name1: str, name2: str) -> PairStatistics:
        """The statistics of the pair of geoms so named (either order)."""
        pair = find_pair([p.pair for p in self.pairs], name1, name2)
        return next(p for p in self.pairs if p.pair == pair)

    def ranked(self) -> list[PairStatistics]:
        """Pairs that touched at least once, most poses first (ties: most contacts)."""
        hit = [p for p in self.pairs if p.poses]
        return sorted(hit, key=lambda p: (-p.poses, -p.contacts, p.pair.label))

    def summary(self) -> str:
        """The share of poses in contact and the number of pairs."""
        return (
            f"{100 * self.share_with_contact:.1f}% of {plural(self.n_poses, 'pose')} in contact, "
            f"{plural(len(self.pairs), 'pair')} tested"
        )

    def html_tables(self) -> list[Table]:
        """Per pair: poses and contacts, and the closest approach with distances."""
        dist = self.distance_engine is not None
        rows = sorted(self.pairs, key=lambda p: (-p.poses, p.closest)) if dist else self.ranked()
        header = ("pair", "poses", "contacts") + (("closest (m)",) if dist else ())
        return [
            table(
                f"{self.n_poses} random poses (seed {self.seed})",
                header,
                [
                    (p.pair.label, p.poses, p.contacts) + ((f"{p.closest:.4f}",) if dist else ())
                    for p in rows
                ],
                (False, True, True, True)[: len(header)],
            )
        ]

    def html_notes(self) -> list[str]:
        """The keyframes' clearance and the engines' disagreements."""
        return self._notes()

    def _notes(self) -> list[str]:
        out = []
        for k in self.keyframes:
            c = k.closest
            near = f", closest {c.pair.label} at {c.distance:.4f} m" if c is not None else ""
            out.append(f"at the {k.keyframe} pose: {k.contacts} contacts{near}")
        if self.distance_engine is not None:
            out.append(
                f"distances by {self.distance_engine}; poses where its touching pairs differ "
                f"from MuJoCo's contacts: {self.disagreements}"
            )
        return out

    def lines(self, top: int | None = None) -> list[str]:
        """The table as text lines: share of poses, then per pair poses and contacts."""
        out = [
            f"{self.n_poses} random poses (seed {self.seed}): {100 * self.share_with_contact:.1f}% "
            f"have at least one self-contact (MuJoCo's contact list)"
        ]
        dist = self.distance_engine is not None
        rows = (
            self.ranked() if not dist else sorted(self.pairs, key=lambda p: (-p.poses, p.closest))
        )[:top]
        # The pair column fits the longest label shown (24 wide at least, as the lesson's).
        w = max([24] + [len(p.pair.label) + 2 for p in rows])
        head = f"  {'pair':<{w}}{'poses':>7}{'contacts':>10}"
        out.append(head + (f"{'closest (m)':>13}" if dist else ""))
        for p in rows:
            line = f"  {p.pair.label:<{w}}{p.poses:>7}{p.contacts:>10}"
            out.append(line + (f"{p.closest:>13.4f}" if dist else ""))
        return out + ["  " + line for line in self._notes()]
