"""The arm's numbers against MuJoCo's model of the whole robot, the held joints at rest."""

from __future__ import annotations

from redundancy.model.robot import difference_to_whole_robot as largest_difference_to_full_model

__all__ = ["largest_difference_to_full_model"]
