"""Analyses over an Arm: cross-checks (single pose and stacks), batched quantities, self-motion."""
